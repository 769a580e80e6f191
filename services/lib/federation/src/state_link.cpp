#include "urs/federation/state_link.hpp"

#include <spdlog/spdlog.h>

#include <condition_variable>
#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "SpaceState.h"
#include "SpaceStatePubSubTypes.h"
#include "dds_identity.hpp"
#include "dds_participant.hpp"
#include "dds_qos.hpp"
#include "urs/world/world.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;
using SystemClock = std::chrono::system_clock;

namespace {

constexpr const char* kComponentTopic = "urs/state/component";
constexpr const char* kPoseTopic = "urs/state/pose";
constexpr const char* kContextTopic = "urs/state/context";
constexpr const char* kEventTopic = "urs/state/event";
constexpr const char* kGone = "Gone";  // ComponentState.state of a component that left its space

template <class Sample>
void stamp_into(Sample& sample, SystemClock::time_point stamp) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(stamp.time_since_epoch()).count();
  sample.sec(ns / 1000000000);
  sample.nsec(static_cast<uint32_t>(ns % 1000000000));
}
template <class Sample>
SystemClock::time_point stamp_of(const Sample& sample) {
  return SystemClock::time_point(std::chrono::duration_cast<SystemClock::duration>(
      std::chrono::seconds(sample.sec()) + std::chrono::nanoseconds(sample.nsec())));
}

// The link's pose topic (every space's robots, shared with the other spaces): a best-effort
// stream where the newest sample is all that matters. Not the world's pose QoS (urs::world:
// reliable, transient-local), which the relay reads from this space's devices.
template <class Qos>
Qos shared_pose_stream_qos(Qos qos) {
  qos.reliability().kind = fdds::BEST_EFFORT_RELIABILITY_QOS;
  qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  qos.resource_limits().max_instances = 10000;
  qos.resource_limits().max_samples_per_instance = 1;
  qos.resource_limits().max_samples = 10000;
  return qos;
}

// Events: every one reaches every matched reader, in order; a writer whose readers lag by more
// than the history blocks the publisher briefly and then refuses (never overwrites unsent ones).
constexpr int32_t kEventHistory = 4096;
template <class Qos>
Qos event_qos(Qos qos) {
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.reliability().max_blocking_time = link_qos::duration(std::chrono::milliseconds(100));
  qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
  qos.resource_limits().max_instances = 1;
  qos.resource_limits().max_samples_per_instance = kEventHistory;
  qos.resource_limits().max_samples = kEventHistory;
  qos.resource_limits().allocated_samples = 16;
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  return qos;
}

// What a refusal names (DdsLink::speaks_for): the kind of sample and its name within its space.
const char* kind_of(const dds::ComponentState&, bool ending) {
  return ending ? "end of component state" : "component state";
}
const char* kind_of(const dds::ContextEntry&, bool ending) { return ending ? "end of context entry" : "context entry"; }
const std::string& name_of(const dds::ComponentState& s) { return s.name(); }
const std::string& name_of(const dds::ContextEntry& s) { return s.key(); }

std::pair<std::string, std::string> key_of(const ComponentState& c) { return {c.space, c.name}; }
std::pair<std::string, std::string> key_of(const ContextState& e) { return {e.space, e.key}; }
bool same(const ComponentState& a, const ComponentState& b) { return a == b; }
bool same(const ContextState& a, const ContextState& b) {
  return a.value_json == b.value_json && a.version == b.version && a.source == b.source;
}

// The other spaces' entries of one keyed topic, read from the reader's cache (keep-last 1 per
// instance) as it is now: the live instances of writers whose liveliness holds, but tombstones and
// the samples of writers that may not speak for the space they name (DdsLink::speaks_for). Each
// reconcile() reports what appeared, changed or ended since the one before, so an end is
// seen however DDS tells it (a tombstone, a writer unmatched or lost, an instance left with no
// writer). Only StateLink's reader thread calls it: never a DDS listener, which runs holding the
// reader's own lock (reading the cache from two threads under two locks would deadlock).
template <class Sample, class Value>
class KeyedIn {
 public:
  using Handler = std::function<void(const Value&, bool alive)>;
  using Convert = std::function<std::optional<Value>(const Sample&)>;  // nullopt: a tombstone
  KeyedIn(Handler handler, Convert convert) : handler_(std::move(handler)), convert_(std::move(convert)) {}

  void attach(fdds::DataReader* reader, DdsLink& link) {
    reader_ = reader;
    link_ = &link;
    own_space_ = link.options().space;
  }
  void writer(const fdds::InstanceHandle_t& writer, bool alive) {
    std::lock_guard lock(mutex_);
    if (alive) {
      dead_.erase(writer);
    } else {
      dead_.insert(writer);
    }
  }
  void reconcile() {
    std::set<fdds::InstanceHandle_t> dead;
    {
      std::lock_guard lock(mutex_);  // never held while DDS is called: listeners take it holding DDS's locks
      dead = dead_;
    }
    // Every instance, ended or not: each space speaks only for itself (StandingInstances).
    std::map<std::pair<std::string, std::string>, Value> now;
    fdds::LoanableSequence<Sample> samples;
    fdds::SampleInfoSeq infos;
    if (reader_->read(samples, infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE, fdds::ANY_VIEW_STATE,
                      fdds::ANY_INSTANCE_STATE) == ReturnCode_t::RETCODE_OK) {
      const auto& instances = taken_.read(
          samples, infos, own_space_, [this](const fdds::SampleInfo& info, const Sample& sample, bool ending) {
            return link_->speaks_for(info, sample.space(), kind_of(sample, ending), name_of(sample));
          });
      reader_->return_loan(samples, infos);
      for (const auto& [instance, taken] : instances) {
        if (!taken.alive || dead.count(taken.info.publication_handle) || taken.sample.space() == own_space_) continue;
        if (auto value = convert_(taken.sample)) now.emplace(key_of(*value), std::move(*value));
      }
    }
    for (const auto& [key, value] : held_) {
      if (!now.count(key) && handler_) handler_(value, false);
    }
    for (const auto& [key, value] : now) {
      auto it = held_.find(key);
      if ((it == held_.end() || !same(it->second, value)) && handler_) handler_(value, true);
    }
    held_ = std::move(now);
  }

 private:
  Handler handler_;
  Convert convert_;
  fdds::DataReader* reader_ = nullptr;
  DdsLink* link_ = nullptr;
  std::string own_space_;
  std::mutex mutex_;                                           // guards dead_
  std::set<fdds::InstanceHandle_t> dead_;                      // writers whose liveliness is lost
  StandingInstances<Sample> taken_;                            // the instances as last read (the reader thread's only)
  std::map<std::pair<std::string, std::string>, Value> held_;  // the reader thread's own
};

}  // namespace

struct StateLink::Impl : public fdds::DataReaderListener {
  Impl(DdsLink& link, StateHandlers handlers)
      : link(link),
        space(link.options().space),
        handlers(std::move(handlers)),
        components_in(this->handlers.component,
                      [](const dds::ComponentState& s) -> std::optional<ComponentState> {
                        if (s.state() == kGone) return std::nullopt;
                        return ComponentState{s.space(),     s.name(), s.kind(),   s.state(),
                                              s.type_name(), s.host(), stamp_of(s)};
                      }),
        context_in(this->handlers.context, [](const dds::ContextEntry& s) -> std::optional<ContextState> {
          if (s.value_json().empty()) return std::nullopt;
          return ContextState{s.space(), s.key(), s.value_json(), s.source(), s.version(), stamp_of(s)};
        }) {}

  DdsLink& link;
  const std::string space;
  StateHandlers handlers;
  fdds::DomainParticipant* participant = nullptr;
  fdds::Publisher* publisher = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  fdds::TypeSupport component_type{new dds::ComponentStatePubSubType()};
  fdds::TypeSupport pose_type{new dds::SpacePosePubSubType()};
  fdds::TypeSupport context_type{new dds::ContextEntryPubSubType()};
  fdds::TypeSupport event_type{new dds::SpaceEventPubSubType()};
  std::vector<fdds::Topic*> topics;
  fdds::DataWriter* component_writer = nullptr;
  fdds::DataWriter* pose_writer = nullptr;
  fdds::DataWriter* context_writer = nullptr;
  fdds::DataWriter* event_writer = nullptr;
  fdds::DataReader* component_reader = nullptr;
  fdds::DataReader* pose_reader = nullptr;
  fdds::DataReader* context_reader = nullptr;
  fdds::DataReader* event_reader = nullptr;

  KeyedIn<dds::ComponentState, ComponentState> components_in;
  KeyedIn<dds::ContextEntry, ContextState> context_in;

  mutable std::mutex mutex;  // guards what is written below
  std::map<std::string, ComponentState> components_out;
  std::map<std::string, ContextState> context_out;                         // by key
  std::map<std::string, std::chrono::steady_clock::time_point> pose_sent;  // by robot

  std::optional<PoseRelay> relay;
  std::unique_ptr<world::World> world;  // last: destroyed first, so no pose arrives after the rest

  fdds::Topic* topic(const char* name, fdds::TypeSupport& type) {
    if (type.register_type(participant) != ReturnCode_t::RETCODE_OK) {
      throw std::runtime_error(std::string("DDS: cannot register type ") + type.get_type_name());
    }
    fdds::Topic* made = participant->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    if (made == nullptr) throw std::runtime_error(std::string("DDS: cannot create topic ") + name);
    topics.push_back(made);
    return made;
  }

  void create(std::chrono::milliseconds lease) {
    // In the shared topics' partitions, as the catalog (shared_partitions(), dds_participant.hpp).
    const DdsOptions& options = link.options();
    const SharedPartitions partitions = shared_partitions(options);
    publisher = create_shared_publisher(participant, partitions.write);
    subscriber = create_shared_subscriber(participant, partitions.read);
    fdds::Topic* components = topic(kComponentTopic, component_type);
    fdds::Topic* poses = topic(kPoseTopic, pose_type);
    fdds::Topic* context = topic(kContextTopic, context_type);
    fdds::Topic* events = topic(kEventTopic, event_type);

    const fdds::DataWriterQos keyed = link_qos::keyed_state_writer(lease);
    component_writer = create_shared_writer(publisher, components, keyed, options);
    context_writer = create_shared_writer(publisher, context, keyed, options);
    pose_writer = create_shared_writer(publisher, poses, shared_pose_stream_qos(fdds::DATAWRITER_QOS_DEFAULT), options);
    fdds::DataWriterQos streamed = event_qos(fdds::DATAWRITER_QOS_DEFAULT);
    streamed.publish_mode().kind = fdds::ASYNCHRONOUS_PUBLISH_MODE;  // payloads up to images
    event_writer = create_shared_writer(publisher, events, streamed, options);

    const fdds::DataReaderQos keyed_in = link_qos::keyed_state_reader(lease);
    component_reader = create_shared_reader(subscriber, components, keyed_in, this, options);
    context_reader = create_shared_reader(subscriber, context, keyed_in, this, options);
    pose_reader =
        create_shared_reader(subscriber, poses, shared_pose_stream_qos(fdds::DATAREADER_QOS_DEFAULT), this, options);
    event_reader = create_shared_reader(subscriber, events, event_qos(fdds::DATAREADER_QOS_DEFAULT), this, options);
    link.keep_alive(component_writer);
    link.keep_alive(context_writer);
    components_in.attach(component_reader, link);
    context_in.attach(context_reader, link);
    reader_thread =
        std::thread([this, lease] { read_state(std::max(std::chrono::milliseconds(50), lease / 4), lease); });
  }

  void destroy() {
    world.reset();
    stop_reader();
    if (subscriber) {
      for (auto* reader : {component_reader, context_reader, pose_reader, event_reader}) {
        if (reader) {
          reader->set_listener(nullptr);
          subscriber->delete_datareader(reader);
        }
      }
      participant->delete_subscriber(subscriber);
    }
    for (auto* writer : {component_writer, context_writer}) {
      if (writer) link.let_go(writer);
    }
    if (publisher) {
      for (auto* writer : {component_writer, context_writer, pose_writer, event_writer}) {
        if (writer) publisher->delete_datawriter(writer);
      }
      participant->delete_publisher(publisher);
    }
    for (auto* made : topics) participant->delete_topic(made);
  }

  // ---- reading ----

  // The listeners run on DDS threads from the moment each reader exists, while create() is still
  // assigning the endpoint members on its own thread: they know a reader by its topic and use the
  // reader they are given, never those members.
  enum class Stream { kComponent, kPose, kContext, kEvent, kOther };
  static Stream stream_of(fdds::DataReader* reader) {
    const std::string& name = reader->get_topicdescription()->get_name();
    if (name == kComponentTopic) return Stream::kComponent;
    if (name == kPoseTopic) return Stream::kPose;
    if (name == kContextTopic) return Stream::kContext;
    if (name == kEventTopic) return Stream::kEvent;
    return Stream::kOther;
  }

  void on_data_available(fdds::DataReader* reader) override {
    switch (stream_of(reader)) {
      case Stream::kComponent:
      case Stream::kContext:
        wake_reader();
        break;
      case Stream::kPose:
        read_poses(reader);
        break;
      case Stream::kEvent:
        read_events(reader);
        break;
      case Stream::kOther:
        break;
    }
  }

  void on_sample_lost(fdds::DataReader* reader, const fdds::SampleLostStatus& status) override {
    if (status.total_count_change > 0) {
      link.count_samples_lost(reader->get_topicdescription()->get_name(),
                              static_cast<uint64_t>(status.total_count_change));
    }
  }

  void read_poses(fdds::DataReader* reader) {
    dds::SpacePose sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data || sample.space() == space || !handlers.pose) continue;
      if (!link.speaks_for(info, sample.space(), "pose of robot", sample.robot())) continue;
      handlers.pose({sample.space(), sample.robot(), sample.x(), sample.y(), sample.theta(), stamp_of(sample)});
    }
  }

  void read_events(fdds::DataReader* reader) {
    dds::SpaceEvent sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data || sample.space() == space || !handlers.event) continue;
      if (!link.speaks_for(info, sample.space(), "event on", sample.topic())) continue;
      handlers.event({sample.space(), sample.seq(), sample.topic(), sample.content_type(), sample.source(),
                      stamp_of(sample), std::string(sample.payload().begin(), sample.payload().end())});
    }
  }

  void writer_state(fdds::DataReader* reader, const fdds::InstanceHandle_t& writer, bool alive) {
    const Stream stream = stream_of(reader);
    if (stream == Stream::kComponent) components_in.writer(writer, alive);
    if (stream == Stream::kContext) context_in.writer(writer, alive);
    wake_reader();
  }

  // ---- the reader thread: the others' components and context, off the DDS threads ----

  std::thread reader_thread;
  std::mutex wake_mutex;
  std::condition_variable wake;
  bool dirty = false;
  bool stopping = false;

  void wake_reader() {
    {
      std::lock_guard lock(wake_mutex);
      dirty = true;
    }
    wake.notify_one();
  }
  // Reconciles when DDS reports a change, and every `period` anyway (an end DDS tells without a
  // listener call is seen then); writes this space's state again every `lease`.
  void read_state(std::chrono::milliseconds period, std::chrono::milliseconds lease) {
    auto rewritten = std::chrono::steady_clock::now();
    std::unique_lock lock(wake_mutex);
    while (!stopping) {
      wake.wait_for(lock, period, [&] { return dirty || stopping; });
      if (stopping) break;
      dirty = false;
      lock.unlock();
      components_in.reconcile();
      context_in.reconcile();
      if (std::chrono::steady_clock::now() - rewritten >= lease) {
        rewrite();
        rewritten = std::chrono::steady_clock::now();
      }
      lock.lock();
    }
  }

  // Every component and context entry written again: a bridge that lost this one (a cut network)
  // and matches it again drops the samples it had seen already and takes only new ones.
  void rewrite() {
    std::lock_guard lock(mutex);
    for (const auto& [name, state] : components_out) write_component(state);
    for (const auto& [key, entry] : context_out) write_context(entry);
  }
  bool write_component(const ComponentState& state) {
    dds::ComponentState sample;
    sample.space(space);
    sample.name(state.name);
    sample.kind(state.kind);
    sample.state(state.state);
    sample.type_name(state.type_name);
    sample.host(state.host);
    stamp_into(sample, state.stamp);
    return component_writer->write(&sample);
  }
  bool write_context(const ContextState& entry) {
    dds::ContextEntry sample;
    sample.space(space);
    sample.key(entry.key);
    sample.value_json(entry.value_json);
    sample.source(entry.source);
    sample.version(entry.version);
    stamp_into(sample, entry.stamp);
    return context_writer->write(&sample);
  }
  void stop_reader() {
    {
      std::lock_guard lock(wake_mutex);
      stopping = true;
    }
    wake.notify_one();
    if (reader_thread.joinable()) reader_thread.join();
  }
  void on_subscription_matched(fdds::DataReader* reader, const fdds::SubscriptionMatchedStatus& status) override {
    if (status.current_count_change != 0) {
      writer_state(reader, status.last_publication_handle, status.current_count_change > 0);
    }
  }
  void on_liveliness_changed(fdds::DataReader* reader, const fdds::LivelinessChangedStatus& status) override {
    if (status.not_alive_count_change > 0) writer_state(reader, status.last_publication_handle, false);
    if (status.alive_count_change > 0) writer_state(reader, status.last_publication_handle, true);
  }

  // ---- poses of this space ----

  void relay_pose(const world::PoseSample& pose) {
    const auto now = std::chrono::steady_clock::now();
    {
      std::lock_guard lock(mutex);
      auto& sent = pose_sent[pose.robot];
      if (now - sent < relay->period) return;
      sent = now;
    }
    dds::SpacePose sample;
    sample.space(space);
    sample.robot(pose.robot);
    sample.x(pose.x);
    sample.y(pose.y);
    sample.theta(pose.theta);
    stamp_into(sample, pose.stamp);
    pose_writer->write(&sample);
  }
};

StateLink::StateLink(DdsLink& link, StateHandlers handlers, std::optional<PoseRelay> poses)
    : impl_(std::make_unique<Impl>(link, std::move(handlers))) {
  Impl& d = *impl_;
  d.participant = link.participant();
  try {
    d.create(link.options().lease);
    if (poses) {
      if (poses->domain == link.options().domain) {
        throw std::runtime_error("the devices' domain " + std::to_string(poses->domain) +
                                 " is the link's: other spaces' robots would be relayed as this space's");
      }
      d.relay = *poses;
      d.world = std::make_unique<world::World>(poses->domain, "urs-bridge/" + link.options().space + "/poses");
      const auto channel = poses->ground_truth ? world::Channel::ground_truth : world::Channel::localizer;
      for (const auto& robot : poses->robots) {
        d.world->subscribe(channel, robot, [&d](const world::PoseSample& pose) { d.relay_pose(pose); });
      }
    }
  } catch (...) {
    d.destroy();
    throw;
  }
}

StateLink::~StateLink() { impl_->destroy(); }

void StateLink::set_component(ComponentState state) {
  Impl& d = *impl_;
  state.space = d.space;
  if (state.stamp == SystemClock::time_point{}) state.stamp = SystemClock::now();
  std::lock_guard lock(d.mutex);
  auto it = d.components_out.find(state.name);
  if (it != d.components_out.end() && it->second == state) return;
  if (!d.write_component(state)) {
    spdlog::warn("dds: the state of {} could not be written", state.name);
    return;
  }
  d.components_out[state.name] = std::move(state);
}

// A component that left is written once more as "Gone" (a tombstone, kept for late joiners)
// rather than disposed: every reader sees it as a plain sample, whatever its vendor.
void StateLink::drop_component(const std::string& name) {
  Impl& d = *impl_;
  std::lock_guard lock(d.mutex);
  auto it = d.components_out.find(name);
  if (it == d.components_out.end()) return;
  dds::ComponentState sample;
  sample.space(d.space);
  sample.name(name);
  sample.kind(it->second.kind);
  sample.state(kGone);
  stamp_into(sample, SystemClock::now());
  if (!d.component_writer->write(&sample)) spdlog::warn("dds: the departure of {} could not be written", name);
  d.components_out.erase(it);
}

void StateLink::set_context(ContextState entry) {
  Impl& d = *impl_;
  if (entry.stamp == SystemClock::time_point{}) entry.stamp = SystemClock::now();
  if (entry.value_json.empty()) return drop_context(entry.key);
  std::lock_guard lock(d.mutex);
  if (!d.write_context(entry)) spdlog::warn("dds: context entry {} could not be written", entry.key);
  d.context_out[entry.key] = std::move(entry);
}

// A removed key is written with an empty value (a tombstone), as drop_component does; only a key
// this link shared has one: any other removal (of a key it never wrote, e.g. one imported from
// another space) is none of its business.
void StateLink::drop_context(const std::string& key) {
  Impl& d = *impl_;
  std::lock_guard lock(d.mutex);
  if (d.context_out.erase(key) == 0) return;
  ContextState removed;
  removed.key = key;
  removed.stamp = SystemClock::now();
  if (!d.write_context(removed)) spdlog::warn("dds: the removal of context entry {} could not be written", key);
}

bool StateLink::publish_event(const SpaceEvent& event) {
  Impl& d = *impl_;
  dds::SpaceEvent sample;
  sample.space(d.space);
  sample.seq(event.seq);
  sample.topic(event.topic);
  sample.content_type(event.content_type);
  sample.source(event.source);
  stamp_into(sample, event.stamp);
  sample.payload(std::vector<uint8_t>(event.payload.begin(), event.payload.end()));
  return d.event_writer->write(&sample);
}

}  // namespace urs::federation
