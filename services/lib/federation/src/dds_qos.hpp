#pragma once
// QoS the bridge's DDS endpoints share (internal to urs::bridge): what DdsLink's catalog and
// descriptions and StateLink's components and context have in common, so that every keyed state
// topic of the link behaves alike for late joiners and lost bridges (docs/federation.md).

#include <chrono>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

namespace urs::federation::link_qos {

inline eprosima::fastrtps::Duration_t duration(std::chrono::milliseconds ms) {
  return eprosima::fastrtps::Duration_t(static_cast<double>(ms.count()) / 1000.0);
}

// How often a reliable writer of the link sends a heartbeat while a sample is unacknowledged
// (Fast DDS's default: 3 s): how long a lost sample waits to be sent again, and how long a retired
// instance (unregistered) stays taken, since readers acknowledge when a heartbeat asks. Nothing
// is sent while every sample is acknowledged.
inline constexpr std::chrono::milliseconds kHeartbeatPeriod{100};
inline void heartbeat_every_period(eprosima::fastdds::dds::DataWriterQos& qos) {
  qos.reliable_writer_qos().times.heartbeatPeriod = duration(kHeartbeatPeriod);
}

// Keyed state: reliable, transient-local, keep-last 1 per instance (a late joiner gets every live
// entry), manual-by-topic liveliness with the link's lease (a silent bridge's entries end within
// it), room for every entry of every space (Fast DDS's default of 10 instances would silently refuse the
// eleventh), and samples sized as they come: a preallocated pool would give every sample the
// type's maximum size, tens of kB for an unbounded sequence (but see ending_state_reader).
template <class Qos>
Qos keyed_state(Qos qos, std::chrono::milliseconds lease) {
  namespace fdds = eprosima::fastdds::dds;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  // Not AUTOMATIC: Fast DDS 2.9 asserts every AUTOMATIC writer a reader tracks whenever any
  // participant's writer asserts (eProsima/Fast-DDS#4373, fixed after 2.9), so
  // a killed bridge's entries lived on as long as another bridge did, until its participant lease
  // ran out. Manual-by-topic liveliness is tracked per writer; the writers assert it
  // (LivelinessAsserter) and a reader asking for it only matches writers that offer it.
  qos.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
  qos.liveliness().lease_duration = duration(lease);
  qos.resource_limits().max_instances = 100000;
  qos.resource_limits().max_samples_per_instance = 1;
  qos.resource_limits().max_samples = 100000;
  qos.resource_limits().allocated_samples = 64;
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  return qos;
}

// The writers of keyed state publish asynchronously: a description or a context value may exceed
// one datagram. Their owner has a LivelinessAsserter assert them four times a lease.
inline eprosima::fastdds::dds::DataWriterQos keyed_state_writer(std::chrono::milliseconds lease) {
  auto qos = keyed_state(eprosima::fastdds::dds::DATAWRITER_QOS_DEFAULT, lease);
  qos.publish_mode().kind = eprosima::fastdds::dds::ASYNCHRONOUS_PUBLISH_MODE;
  heartbeat_every_period(qos);
  return qos;
}
inline eprosima::fastdds::dds::DataReaderQos keyed_state_reader(std::chrono::milliseconds lease) {
  return keyed_state(eprosima::fastdds::dds::DATAREADER_QOS_DEFAULT, lease);
}
// A reader of keyed state whose instances its writers end (dispose, unregister): the catalog.
// The default memory policy (PREALLOCATED_WITH_REALLOC, every sample room for the type's maximum
// size, a few kB for an entry) instead of a dynamic payload pool: from another process, a dispose or
// an unregistration is a message with an empty payload, which Fast DDS 2.9's dynamic pools refuse;
// the reliable reader then waits for that sample forever and shows nothing its writer writes after
// it (what it had of that writer goes too, each instance as its writer writes it again).
inline eprosima::fastdds::dds::DataReaderQos ending_state_reader(std::chrono::milliseconds lease) {
  auto qos = keyed_state_reader(lease);
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_WITH_REALLOC_MEMORY_MODE;
  return qos;
}

}  // namespace urs::federation::link_qos
