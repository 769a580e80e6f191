#pragma once
// QoS the bridge's DDS endpoints share (internal to urs::bridge): what DdsLink's catalog and
// descriptions and StateLink's components and context have in common, so that every keyed state
// topic of the link behaves alike for late joiners and lost bridges (docs/federation.md).

#include <chrono>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

namespace urs::bridge::link_qos {

inline eprosima::fastrtps::Duration_t duration(std::chrono::milliseconds ms) {
  return eprosima::fastrtps::Duration_t(static_cast<double>(ms.count()) / 1000.0);
}

// Keyed state: reliable, transient-local, keep-last 1 per instance (a late joiner gets every live
// entry), automatic liveliness with the link's lease (a silent bridge's entries end within it),
// room for every entry of every space (Fast DDS's default of 10 instances would silently refuse the
// eleventh), and samples sized as they come: a preallocated pool would give every sample the
// type's maximum size, tens of kB for an unbounded sequence.
template <class Qos>
Qos keyed_state(Qos qos, std::chrono::milliseconds lease) {
  namespace fdds = eprosima::fastdds::dds;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  qos.liveliness().kind = fdds::AUTOMATIC_LIVELINESS_QOS;
  qos.liveliness().lease_duration = duration(lease);
  qos.resource_limits().max_instances = 100000;
  qos.resource_limits().max_samples_per_instance = 1;
  qos.resource_limits().max_samples = 100000;
  qos.resource_limits().allocated_samples = 64;
  qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  return qos;
}

// The writers of keyed state also announce their liveliness four times a lease, and publish
// asynchronously: a description or a context value may exceed one datagram.
inline eprosima::fastdds::dds::DataWriterQos keyed_state_writer(std::chrono::milliseconds lease) {
  auto qos = keyed_state(eprosima::fastdds::dds::DATAWRITER_QOS_DEFAULT, lease);
  qos.liveliness().announcement_period = duration(lease / 4);
  qos.publish_mode().kind = eprosima::fastdds::dds::ASYNCHRONOUS_PUBLISH_MODE;
  return qos;
}
inline eprosima::fastdds::dds::DataReaderQos keyed_state_reader(std::chrono::milliseconds lease) {
  return keyed_state(eprosima::fastdds::dds::DATAREADER_QOS_DEFAULT, lease);
}

}  // namespace urs::bridge::link_qos
