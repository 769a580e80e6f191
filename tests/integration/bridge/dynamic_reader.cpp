// A DDS reader that knows no type: it reads every topic of a domain whose name starts with a
// prefix, with the types the writers announce at run time (XTypes TypeObjects in their discovery
// data, turned into Fast DDS DynamicTypes), as a generic tool of another party would. None of
// URSLink's types is compiled in: it links Fast DDS, and urs::util for JSON text.
//
//   dynamic_reader DOMAIN PREFIX SECONDS
//
// Prints one line per event on stdout, flushed, for the test driving it:
//   type <topic> struct <name> { <members as IDL>; }   an endpoint of <topic> announced a type it
//                                   could build (once per type; <name> as its TypeObject says)
//   reading <topic>                 a reader of <topic> exists (the writer's reliability and durability)
//   matched <topic> <n>             it has <n> writers now
//   incompatible <topic> policy <id>  a writer of <topic> offers QoS it cannot match
//   {"topic":...,"type":...,"value":{...}}   one sample, its members as JSON (byte sequences as
//                                   base64 strings, 64-bit integers as JSON numbers)
// and exits 0 after SECONDS, 2 on bad arguments or when DDS refuses.

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/types/DynamicData.h>
#include <fastrtps/types/DynamicDataFactory.h>
#include <fastrtps/types/DynamicPubSubType.h>
#include <fastrtps/types/DynamicType.h>
#include <fastrtps/types/DynamicTypeMember.h>
#include <fastrtps/types/MemberDescriptor.h>
#include <fastrtps/types/TypeDescriptor.h>

#include <chrono>
#include <condition_variable>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "urs/util/json_text.hpp"

namespace {

namespace fdds = eprosima::fastdds::dds;
namespace types = eprosima::fastrtps::types;

std::mutex out_mutex;

void say(const std::string& line) {
  std::lock_guard lock(out_mutex);
  std::cout << line << std::endl;
}

using urs::util::base64;
using urs::util::json_string;

// One value of `data` (member or element `id`) of kind `type`, as JSON.
std::string json_of(types::DynamicData* data, types::MemberId id, const types::DynamicType_ptr& type);

std::string json_of_struct(types::DynamicData* data, const types::DynamicType_ptr& type) {
  std::map<types::MemberId, types::DynamicTypeMember*> members;
  type->get_all_members(members);
  std::string out = "{";
  for (const auto& [id, member] : members) {
    if (out.size() > 1) out += ",";
    out += json_string(member->get_name()) + ":" + json_of(data, id, member->get_descriptor()->get_type());
  }
  return out + "}";
}

std::string json_of_collection(types::DynamicData* data, const types::DynamicType_ptr& type) {
  const types::DynamicType_ptr element = type->get_type_descriptor()->get_element_type();
  const uint32_t count = data->get_item_count();
  if (element->get_kind() == types::TK_BYTE) {
    std::string bytes(count, '\0');
    for (uint32_t i = 0; i < count; ++i) data->get_byte_value(reinterpret_cast<uint8_t&>(bytes[i]), i);
    return json_string(base64(bytes));
  }
  std::string out = "[";
  for (uint32_t i = 0; i < count; ++i) {
    if (i > 0) out += ",";
    out += json_of(data, i, element);
  }
  return out + "]";
}

// A number member or element, read with `get` (DynamicData's getter of its type).
template <class T>
std::string number_of(types::DynamicData* data, types::MemberId id,
                      ReturnCode_t (types::DynamicData::*get)(T&, types::MemberId) const) {
  T value{};
  (data->*get)(value, id);
  std::ostringstream out;
  out.precision(17);
  out << +value;  // octets as numbers, not characters
  return out.str();
}

std::string json_of(types::DynamicData* data, types::MemberId id, const types::DynamicType_ptr& type) {
  using D = types::DynamicData;
  switch (type->get_kind()) {
    case types::TK_BOOLEAN: {
      bool value = false;
      data->get_bool_value(value, id);
      return value ? "true" : "false";
    }
    case types::TK_BYTE:
      return number_of<types::octet>(data, id, &D::get_byte_value);
    case types::TK_INT16:
      return number_of<int16_t>(data, id, &D::get_int16_value);
    case types::TK_UINT16:
      return number_of<uint16_t>(data, id, &D::get_uint16_value);
    case types::TK_INT32:
      return number_of<int32_t>(data, id, &D::get_int32_value);
    case types::TK_UINT32:
      return number_of<uint32_t>(data, id, &D::get_uint32_value);
    case types::TK_INT64:
      return number_of<int64_t>(data, id, &D::get_int64_value);
    case types::TK_UINT64:
      return number_of<uint64_t>(data, id, &D::get_uint64_value);
    case types::TK_FLOAT32:
      return number_of<float>(data, id, &D::get_float32_value);
    case types::TK_FLOAT64:
      return number_of<double>(data, id, &D::get_float64_value);
    case types::TK_STRING8: {
      std::string value;
      data->get_string_value(value, id);
      return json_string(value);
    }
    case types::TK_STRUCTURE:
    case types::TK_SEQUENCE:
    case types::TK_ARRAY: {
      types::DynamicData* inner = data->loan_value(id);
      if (inner == nullptr) return "null";
      const std::string text =
          type->get_kind() == types::TK_STRUCTURE ? json_of_struct(inner, type) : json_of_collection(inner, type);
      data->return_loaned_value(inner);
      return text;
    }
    default:
      return json_string("(kind " + std::to_string(type->get_kind()) + " not shown)");
  }
}

// A type as IDL would declare it, e.g. "struct m::S { @key string id; sequence<octet> data; }".
std::string idl_of(const types::DynamicType_ptr& type);

std::string member_idl(const std::string& name, const types::DynamicType_ptr& type) {
  if (type->get_kind() == types::TK_ARRAY) {
    const types::TypeDescriptor* array = type->get_type_descriptor();
    std::string dims;
    for (uint32_t i = 0; i < array->get_bounds_size(); ++i) dims += "[" + std::to_string(array->get_bounds(i)) + "]";
    return idl_of(array->get_element_type()) + " " + name + dims;
  }
  return idl_of(type) + " " + name;
}

std::string idl_of(const types::DynamicType_ptr& type) {
  const types::TypeDescriptor* descriptor = type->get_type_descriptor();
  switch (type->get_kind()) {
    case types::TK_BOOLEAN:
      return "boolean";
    case types::TK_BYTE:
      return "octet";
    case types::TK_INT16:
      return "short";
    case types::TK_UINT16:
      return "unsigned short";
    case types::TK_INT32:
      return "long";
    case types::TK_UINT32:
      return "unsigned long";
    case types::TK_INT64:
      return "long long";
    case types::TK_UINT64:
      return "unsigned long long";
    case types::TK_FLOAT32:
      return "float";
    case types::TK_FLOAT64:
      return "double";
    case types::TK_CHAR8:
      return "char";
    case types::TK_STRING8: {
      const uint32_t bound = descriptor->get_bounds(0);
      return bound == types::BOUND_UNLIMITED ? "string" : "string<" + std::to_string(bound) + ">";
    }
    case types::TK_SEQUENCE: {
      const uint32_t bound = descriptor->get_bounds(0);
      return "sequence<" + idl_of(descriptor->get_element_type()) +
             (bound == types::BOUND_UNLIMITED ? "" : ", " + std::to_string(bound)) + ">";
    }
    case types::TK_STRUCTURE: {
      std::map<types::MemberId, types::DynamicTypeMember*> members;
      type->get_all_members(members);
      std::string out = "struct " + type->get_name() + " {";
      for (const auto& [id, member] : members) {
        out += member->get_descriptor()->annotation_is_key() ? " @key " : " ";
        out += member_idl(member->get_name(), member->get_descriptor()->get_type()) + ";";
      }
      return out + " }";
    }
    default:
      return "(kind " + std::to_string(type->get_kind()) + ")";
  }
}

struct Discovered {
  std::string type_name;
  fdds::ReliabilityQosPolicyKind reliability;
  fdds::DurabilityQosPolicyKind durability;
};

class Reader : public fdds::DomainParticipantListener {
 public:
  Reader(uint32_t domain, std::string prefix) : prefix_(std::move(prefix)) {
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
    qos.name("dynamic_reader");
    // UDP only, as between hosts: nothing may reach this reader through shared memory alone.
    qos.transport().use_builtin_transports = false;
    qos.transport().user_transports.push_back(std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>());
    participant_ = factory->create_participant(domain, qos, this, fdds::StatusMask::none());
    if (participant_ == nullptr) throw std::runtime_error("cannot join domain " + std::to_string(domain));
    subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  }
  ~Reader() override {
    participant_->set_listener(nullptr);
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }

  // Creates the readers of every topic whose writer and type are both known, until `until`. DDS
  // is never called holding mutex_: the discovery callbacks take it holding DDS's own locks.
  void run(std::chrono::steady_clock::time_point until) {
    std::unique_lock lock(mutex_);
    while (wake_.wait_until(lock, until, [&] { return changed_; })) {
      changed_ = false;
      std::vector<std::tuple<std::string, Discovered, types::DynamicType_ptr>> ready;
      for (const auto& [topic, found] : topics_) {
        auto type = types_.find(found.type_name);
        if (type != types_.end() && subscribed_.insert(topic).second) ready.emplace_back(topic, found, type->second);
      }
      lock.unlock();
      for (const auto& [topic, found, type] : ready) subscribe(topic, found, type);
      lock.lock();
    }
  }

 private:
  struct TopicReader : public fdds::DataReaderListener {
    std::string topic;
    types::DynamicType_ptr type;
    void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& status) override {
      say("matched " + topic + " " + std::to_string(status.current_count));
    }
    void on_requested_incompatible_qos(fdds::DataReader*, const fdds::RequestedIncompatibleQosStatus& status) override {
      say("incompatible " + topic + " policy " + std::to_string(status.last_policy_id));
    }
    void on_data_available(fdds::DataReader* reader) override {
      types::DynamicData_ptr data(types::DynamicDataFactory::get_instance()->create_data(type));
      fdds::SampleInfo info;
      while (reader->take_next_sample(data.get(), &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data) continue;
        say("{\"topic\":" + json_string(topic) + ",\"type\":" + json_string(type->get_name()) +
            ",\"value\":" + json_of_struct(data.get(), type) + "}");
      }
    }
  };

  // On run()'s thread only, without mutex_.
  void subscribe(const std::string& topic_name, const Discovered& found, const types::DynamicType_ptr& type) {
    fdds::TypeSupport support(new types::DynamicPubSubType(type));
    support->auto_fill_type_object(false);
    support->auto_fill_type_information(false);
    if (support.register_type(participant_, found.type_name) != ReturnCode_t::RETCODE_OK) {
      say("error cannot register type " + found.type_name);
      return;
    }
    fdds::Topic* topic = participant_->create_topic(topic_name, found.type_name, fdds::TOPIC_QOS_DEFAULT);
    if (topic == nullptr) {
      say("error cannot create topic " + topic_name);
      return;
    }
    auto listener = std::make_unique<TopicReader>();
    listener->topic = topic_name;
    listener->type = type;
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = found.reliability;
    qos.durability().kind = found.durability;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    // Room for every instance: a keyed writer's history may hold many (a late joiner of the call
    // topics is sent the end of every call still in it), and Fast DDS's default of 10 would
    // refuse all samples of later ones.
    qos.resource_limits().max_instances = fdds::LENGTH_UNLIMITED;
    qos.resource_limits().max_samples_per_instance = fdds::LENGTH_UNLIMITED;
    qos.resource_limits().max_samples = fdds::LENGTH_UNLIMITED;
    // Not a dynamic payload pool: for a DynamicType of unbounded size, Fast DDS 2.9's pools refuse
    // the empty payload that ends an instance ("Problem copying CacheChange, received data is: 0
    // bytes"), and a reliable reader then waits for that sample forever, reading nothing more.
    qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
    if (subscriber_->create_datareader(topic, qos, listener.get()) == nullptr) {
      say("error cannot create a reader of " + topic_name);
      return;
    }
    readers_.push_back(std::move(listener));
    say("reading " + topic_name);
  }

  // DomainParticipantListener
  // The type a remote endpoint announced, built by Fast DDS from its TypeObject. Printed as IDL, but
  // for the name, which is the one the TypeObject itself carries (Fast DDS names the DynamicType
  // after the endpoint's type name).
  void on_type_discovery(fdds::DomainParticipant*, const eprosima::fastrtps::rtps::SampleIdentity&,
                         const eprosima::fastrtps::string_255& topic, const types::TypeIdentifier*,
                         const types::TypeObject* object, types::DynamicType_ptr type) override {
    if (!type || object == nullptr || topic.to_string().rfind(prefix_, 0) != 0) return;
    {
      std::lock_guard lock(mutex_);
      if (!types_.emplace(type->get_name(), type).second) return;
      changed_ = true;
    }
    std::string idl = idl_of(type);
    if (type->get_kind() == types::TK_STRUCTURE && object->_d() == types::EK_COMPLETE) {
      idl = "struct " + object->complete().struct_type().header().detail().type_name() + idl.substr(idl.find(" {"));
    }
    say("type " + topic.to_string() + " " + idl);
    wake_.notify_one();
  }
  void on_publisher_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    if (info.status != eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER) return;
    const std::string topic = info.info.topicName().to_string();
    if (topic.rfind(prefix_, 0) != 0) return;
    {
      std::lock_guard lock(mutex_);
      topics_.emplace(topic, Discovered{info.info.typeName().to_string(), info.info.m_qos.m_reliability.kind,
                                        info.info.m_qos.m_durability.kind});
      changed_ = true;
    }
    wake_.notify_one();
  }

  const std::string prefix_;
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;  // guards what follows
  std::condition_variable wake_;
  bool changed_ = false;
  std::map<std::string, types::DynamicType_ptr> types_;  // by type name
  std::map<std::string, Discovered> topics_;             // by topic name
  std::set<std::string> subscribed_;                     // topics
  std::vector<std::unique_ptr<TopicReader>> readers_;    // run()'s own
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: dynamic_reader DOMAIN PREFIX SECONDS\n";
    return 2;
  }
  try {
    Reader reader(static_cast<uint32_t>(std::stoul(argv[1])), argv[2]);
    say("ready");
    reader.run(std::chrono::steady_clock::now() + std::chrono::seconds(std::stoul(argv[3])));
  } catch (const std::exception& e) {
    std::cerr << "dynamic_reader: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
