#pragma once
// LinkParticipant (internal to urs::bridge): the DdsLink's Fast DDS participant and what the
// link's components create their endpoints on: its publisher and subscriber, the link's four
// types (idl/dds/Federation.idl) and its topics by name. join() sets the participant up from the
// options: transports (UDP, shared memory unless udp_only), initial peers, discovery server or
// client, DDS-Security, leases.
//
// Threads: join() and leave() from the owner only (DdsLink's constructor and destructor); topic()
// from any thread (its own lock, never held while Fast DDS calls back). The entities belong to the
// participant: leave() deletes them all, the endpoints the components made included.

#include <map>
#include <mutex>
#include <string>

#include <fastdds/dds/topic/TypeSupport.hpp>

#include "urs/bridge/dds_link.hpp"

// What the link's components keep pointers to, declared once for their headers.
namespace eprosima::fastdds::dds {
class DataReader;
class DataReaderListener;
class DomainParticipantListener;
class DataWriter;
class Publisher;
class Subscriber;
class Topic;
}  // namespace eprosima::fastdds::dds

namespace urs::bridge {

class LinkParticipant {
 public:
  LinkParticipant();
  LinkParticipant(const LinkParticipant&) = delete;
  LinkParticipant& operator=(const LinkParticipant&) = delete;

  // Joins options.domain with `listener` (if any) told of the participants discovered; throws
  // std::runtime_error if DDS refuses (bad domain, bad peer or discovery server address, security
  // files that do not check out). `listener` outlives the participant (until leave()).
  void join(const DdsOptions& options, eprosima::fastdds::dds::DomainParticipantListener* listener = nullptr);
  // Leaves the domain: no listener is called any more, every entity is deleted. Idempotent.
  void leave();

  eprosima::fastdds::dds::DomainParticipant* participant() const { return participant_; }
  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }

  eprosima::fastdds::dds::TypeSupport entry_type;
  eprosima::fastdds::dds::TypeSupport interface_type;
  eprosima::fastdds::dds::TypeSupport request_type;
  eprosima::fastdds::dds::TypeSupport reply_type;

  // The topic `name` of `type`, made the first time; throws std::runtime_error if DDS refuses.
  eprosima::fastdds::dds::Topic* topic(const std::string& name, eprosima::fastdds::dds::TypeSupport& type);

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;  // guards topics_
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
};

}  // namespace urs::bridge
