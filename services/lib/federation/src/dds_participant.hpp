#pragma once
// LinkParticipant (internal to urs::bridge): the DdsLink's Fast DDS participant and what the
// link's components create their endpoints on: its publisher and subscriber, the link's four
// types (idl/dds/Federation.idl) and its topics by name. join() sets the participant up from the
// options: transports (UDP, shared memory unless udp_only), initial peers, discovery server or
// client, DDS-Security, leases. The shared topics (urs/catalog, urs/interface, urs/state/*) have a
// publisher and subscriber of their own, in the partitions of shared_partitions().
//
// Threads: join() and leave() from the owner only (DdsLink's constructor and destructor); topic()
// from any thread (its own lock, never held while Fast DDS calls back). The entities belong to the
// participant: leave() deletes them all, the endpoints the components made included.

#include <fastdds/dds/topic/TypeSupport.hpp>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "urs/federation/dds_link.hpp"

// What the link's components keep pointers to, declared once for their headers.
namespace eprosima::fastdds::dds {
class DataReader;
class DataReaderListener;
class DomainParticipantListener;
class DataReaderQos;
class DataWriter;
class DataWriterQos;
class DomainParticipant;
class Publisher;
class Subscriber;
class Topic;
}  // namespace eprosima::fastdds::dds

namespace urs::federation {

// Where the link of `options` shares the catalog, descriptions and state: on a secured link its
// writers in the partition of its own space and its readers in the partitions its permissions let
// it read (read_partitions(), dds_security.hpp: "*" unless deploy/pki.sh member --reads narrowed
// them); on a plain link the default partition (both empty), where third-party peers write.
// Throws std::runtime_error if the permissions cannot be read.
struct SharedPartitions {
  std::vector<std::string> write;
  std::vector<std::string> read;
};
SharedPartitions shared_partitions(const DdsOptions& options);

// A publisher (subscriber) of `participant` in `partitions`; throws std::runtime_error if DDS refuses.
eprosima::fastdds::dds::Publisher* create_shared_publisher(eprosima::fastdds::dds::DomainParticipant* participant,
                                                           const std::vector<std::string>& partitions);
eprosima::fastdds::dds::Subscriber* create_shared_subscriber(eprosima::fastdds::dds::DomainParticipant* participant,
                                                             const std::vector<std::string>& partitions);

// An endpoint of a shared topic on `publisher` (`subscriber`). If DDS refuses it (Fast DDS only
// returns nullptr), logs and throws std::runtime_error naming the topic, the partition and what the
// member's permissions grant (partition_refusal(), dds_security.hpp), or DDS's refusal on a plain link.
eprosima::fastdds::dds::DataWriter* create_shared_writer(eprosima::fastdds::dds::Publisher* publisher,
                                                         eprosima::fastdds::dds::Topic* topic,
                                                         const eprosima::fastdds::dds::DataWriterQos& qos,
                                                         const DdsOptions& options);
eprosima::fastdds::dds::DataReader* create_shared_reader(eprosima::fastdds::dds::Subscriber* subscriber,
                                                         eprosima::fastdds::dds::Topic* topic,
                                                         const eprosima::fastdds::dds::DataReaderQos& qos,
                                                         eprosima::fastdds::dds::DataReaderListener* listener,
                                                         const DdsOptions& options);

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
  // The publisher and subscriber of the shared topics (the ones above on a plain link).
  eprosima::fastdds::dds::Publisher* shared_publisher() const { return shared_publisher_; }
  eprosima::fastdds::dds::Subscriber* shared_subscriber() const { return shared_subscriber_; }

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
  eprosima::fastdds::dds::Publisher* shared_publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* shared_subscriber_ = nullptr;
  std::mutex mutex_;  // guards topics_
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
};

}  // namespace urs::federation
