#include "urs/world/world.hpp"

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <mutex>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "WorldState.h"
#include "WorldStatePubSubTypes.h"

namespace urs::world {

namespace fdds = eprosima::fastdds::dds;

namespace {

void split_stamp(std::chrono::system_clock::time_point stamp, int64_t& sec, uint32_t& nsec) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(stamp.time_since_epoch()).count();
  sec = ns / 1'000'000'000;
  nsec = static_cast<uint32_t>(ns % 1'000'000'000);
}

std::chrono::system_clock::time_point join_stamp(int64_t sec, uint32_t nsec) {
  return std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::seconds(sec) + std::chrono::nanoseconds(nsec)));
}

// The two DDS types share every field but the covariance, which only a measurement carries.
template <class T>
T to_wire(const PoseSample& s) {
  T d;
  d.robot(s.robot);
  d.x(s.x);
  d.y(s.y);
  d.theta(s.theta);
  if constexpr (std::is_same_v<T, dds::RobotPoseEstimate>) d.covariance(s.covariance);
  if constexpr (std::is_same_v<T, dds::RobotPose>) d.sim_time(s.sim_time);
  split_stamp(s.stamp, d.sec(), d.nsec());
  return d;
}

template <class T>
PoseSample from_wire(const T& d) {
  PoseSample s;
  s.robot = d.robot();
  s.x = d.x();
  s.y = d.y();
  s.theta = d.theta();
  if constexpr (std::is_same_v<T, dds::RobotPoseEstimate>) s.covariance = d.covariance();
  if constexpr (std::is_same_v<T, dds::RobotPose>) s.sim_time = d.sim_time();
  s.stamp = join_stamp(d.sec(), d.nsec());
  return s;
}

template <class T>
class PoseListener : public fdds::DataReaderListener {
 public:
  PoseListener(std::string robot, World::Handler handler) : robot_(std::move(robot)), handler_(std::move(handler)) {}

  void on_data_available(fdds::DataReader* reader) override {
    T sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      // Every robot's instance arrives on the topic; the key is compared here rather than with a
      // content filter so that the reader stays a plain one any vendor's writer can match.
      if (info.valid_data && sample.robot() == robot_) handler_(from_wire(sample));
    }
  }

 private:
  std::string robot_;
  World::Handler handler_;
};

// The world's pose topics (ground truth and measurements): reliable, keep-last 1 per robot,
// transient-local, so a late joiner gets every robot's latest pose. The same on writers and
// readers, or they would not match.
template <class Qos>
Qos world_pose_qos(Qos qos) {
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  return qos;
}

}  // namespace

struct World::Impl {
  struct Endpoint {
    fdds::TypeSupport type;
    fdds::Topic* topic = nullptr;
    fdds::DataWriter* writer = nullptr;
  };

  std::mutex mutex;
  fdds::DomainParticipant* participant = nullptr;
  fdds::Publisher* publisher = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  Endpoint ground_truth{fdds::TypeSupport(new dds::RobotPosePubSubType())};
  Endpoint localizer{fdds::TypeSupport(new dds::RobotPoseEstimatePubSubType())};
  // Destroyed after the participant, so no DDS thread is still inside one.
  std::vector<std::unique_ptr<fdds::DataReaderListener>> listeners;

  Endpoint& endpoint(Channel channel) { return channel == Channel::ground_truth ? ground_truth : localizer; }
  static const char* topic_name(Channel channel) {
    return channel == Channel::ground_truth ? kGroundTruthTopic : kLocalizerTopic;
  }

  // Caller holds the mutex.
  fdds::Topic* topic(Channel channel) {
    Endpoint& e = endpoint(channel);
    if (e.topic == nullptr) {
      if (e.type.register_type(participant) != ReturnCode_t::RETCODE_OK) {
        throw std::runtime_error(std::string("DDS: cannot register the type of topic ") + topic_name(channel));
      }
      e.topic = participant->create_topic(topic_name(channel), e.type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
      if (e.topic == nullptr) throw std::runtime_error(std::string("DDS: cannot create topic ") + topic_name(channel));
    }
    return e.topic;
  }

  template <class T>
  bool write(Channel channel, const PoseSample& sample) {
    fdds::DataWriter* writer = nullptr;
    {
      std::lock_guard<std::mutex> lock(mutex);
      Endpoint& e = endpoint(channel);
      if (e.writer == nullptr) {
        e.writer = publisher->create_datawriter(topic(channel), world_pose_qos(fdds::DATAWRITER_QOS_DEFAULT));
      }
      writer = e.writer;
    }
    if (writer == nullptr) return false;
    T data = to_wire<T>(sample);
    return writer->write(&data);
  }

  template <class T>
  void read(Channel channel, const std::string& robot, Handler handler) {
    std::lock_guard<std::mutex> lock(mutex);
    auto listener = std::make_unique<PoseListener<T>>(robot, std::move(handler));
    const auto qos = world_pose_qos(fdds::DATAREADER_QOS_DEFAULT);
    if (subscriber->create_datareader(topic(channel), qos, listener.get()) == nullptr) {
      throw std::runtime_error(std::string("DDS: cannot create a reader of topic ") + topic_name(channel));
    }
    listeners.push_back(std::move(listener));
  }
};

World::World(uint32_t domain, const std::string& participant_name) : impl_(std::make_unique<Impl>()) {
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  // The default QoS of the XML profile FASTRTPS_DEFAULT_PROFILES_FILE names (e.g. UDP only between
  // containers), if any: a copy of PARTICIPANT_QOS_DEFAULT would ignore it.
  factory->load_profiles();
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  qos.name(participant_name);
  impl_->participant = factory->create_participant(domain, qos);
  if (impl_->participant == nullptr) {
    throw std::runtime_error("DDS: cannot create a participant in domain " + std::to_string(domain));
  }
  impl_->publisher = impl_->participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  impl_->subscriber = impl_->participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (impl_->publisher == nullptr || impl_->subscriber == nullptr) {
    impl_->participant->delete_contained_entities();
    factory->delete_participant(impl_->participant);
    throw std::runtime_error("DDS: cannot create a publisher and subscriber in domain " + std::to_string(domain));
  }
}

World::~World() {
  impl_->participant->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(impl_->participant);
}

bool World::publish(Channel channel, const PoseSample& sample) {
  return channel == Channel::ground_truth ? impl_->write<dds::RobotPose>(channel, sample)
                                          : impl_->write<dds::RobotPoseEstimate>(channel, sample);
}

void World::subscribe(Channel channel, const std::string& robot, Handler handler) {
  if (channel == Channel::ground_truth) {
    impl_->read<dds::RobotPose>(channel, robot, std::move(handler));
  } else {
    impl_->read<dds::RobotPoseEstimate>(channel, robot, std::move(handler));
  }
}

}  // namespace urs::world
