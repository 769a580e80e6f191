#pragma once
// What the calling and the serving side of the DdsLink agree on (internal to urs::bridge): the
// DDS-RPC topics, their QoS, the limits on calls in flight and the default deadline
// (docs/federation.md, Calls). Definitions only, no state.

#include <chrono>
#include <cstdint>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <string>
#include <vector>

#include "dds_qos.hpp"

namespace urs::federation::dds_rpc {

// Calls in flight per request or reply writer (instances it keeps registered): beyond, a call is
// refused rather than an older one's request dropped.
constexpr int32_t kRpcInFlight = 4096;
// How long a replier remembers the requests it executed (against a second delivery of one) and a
// oneway request stays available to a replier that matches late: requests carry their deadline,
// oneway ones none.
constexpr std::chrono::milliseconds kDefaultDeadline{10000};

inline std::string request_topic(const std::string& space) { return "urs/rpc/" + space + "/request"; }
inline std::string reply_topic(const std::string& space) { return "urs/rpc/" + space + "/reply"; }

inline std::vector<uint8_t> bytes_of(const std::string& text) { return {text.begin(), text.end()}; }
inline std::string text_of(const std::vector<uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

// Reliable and transient-local, keyed by request id (keep-last 1 per instance): a reader that
// matches a writer after a request or reply was written (discovery is not symmetric: a writer
// may see a reader before the reader sees it, and a volatile reader then never gets what was
// written in between) still receives it, as long as its writer keeps it registered. The same
// on writers and readers, or they would not match.
template <class Qos>
Qos rpc_qos(Qos qos) {
  namespace fdds = eprosima::fastdds::dds;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  qos.resource_limits().max_instances = kRpcInFlight;
  qos.resource_limits().max_samples_per_instance = 1;
  qos.resource_limits().max_samples = kRpcInFlight;
  qos.resource_limits().allocated_samples = 16;
  return qos;
}
inline eprosima::fastdds::dds::DataWriterQos rpc_writer_qos() {
  eprosima::fastdds::dds::DataWriterQos qos = rpc_qos(eprosima::fastdds::dds::DATAWRITER_QOS_DEFAULT);
  // Sent from the calling thread: the asynchronous publisher's thread cost a wake-up per message
  // and spun on the writer's lock (docs/performance.md). Fast DDS 2.9 fragments large payloads
  // in this mode too.
  qos.publish_mode().kind = eprosima::fastdds::dds::SYNCHRONOUS_PUBLISH_MODE;
  // A retired request or reply holds its instance until the readers acknowledged it: with Fast
  // DDS's 3 s heartbeat period a burst of over kRpcInFlight calls within 3 s found every instance
  // taken and was refused.
  link_qos::heartbeat_every_period(qos);
  return qos;
}
inline eprosima::fastdds::dds::DataReaderQos rpc_reader_qos() {
  return rpc_qos(eprosima::fastdds::dds::DATAREADER_QOS_DEFAULT);
}

}  // namespace urs::federation::dds_rpc
