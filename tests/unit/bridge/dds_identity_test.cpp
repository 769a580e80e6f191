// Each space speaks only for itself (DdsIdentities::speaks_for): on a secured link a sample naming
// a space is taken only from a participant that proved that space, a refusal logged once per
// writer and space; on a plain link every sample is taken. The participants are told to the
// listener as Fast DDS tells them (ParticipantDiscoveryInfo), with no network.

#include "dds_identity.hpp"

#include <fastdds/rtps/builtin/data/ParticipantProxyData.h>
#include <fastdds/rtps/participant/ParticipantDiscoveryInfo.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <cstring>
#include <fastdds/rtps/attributes/RTPSParticipantAllocationAttributes.hpp>
#include <sstream>

namespace urs::federation {
namespace {

namespace rtps = eprosima::fastrtps::rtps;

// The warnings logged while it lives.
class CapturedLog {
 public:
  CapturedLog() : previous_(spdlog::default_logger()) {
    auto logger = std::make_shared<spdlog::logger>("capture", std::make_shared<spdlog::sinks::ostream_sink_mt>(text_));
    logger->set_level(spdlog::level::warn);
    spdlog::set_default_logger(logger);
  }
  ~CapturedLog() { spdlog::set_default_logger(previous_); }
  std::string text() const { return text_.str(); }
  std::size_t count(const std::string& part) const {
    const std::string all = text();
    std::size_t n = 0;
    for (auto at = all.find(part); at != std::string::npos; at = all.find(part, at + 1)) ++n;
    return n;
  }

 private:
  std::ostringstream text_;
  std::shared_ptr<spdlog::logger> previous_;
};

std::string subject_of(const std::string& space) { return "/O=URSLink federation/CN=" + space; }

// A participant whose GUID prefix is the one PKI-DH derives from `subject` (`tail` in its last
// bytes, as the rest of a real prefix), or a prefix that does not derive from it (`forged`).
rtps::ParticipantProxyData participant(const std::string& subject, uint8_t tail, bool forged = false) {
  rtps::ParticipantProxyData data{rtps::RTPSParticipantAllocationAttributes()};
  const std::optional<GuidPrefix> key = participant_key_of(subject);
  EXPECT_TRUE(key) << subject;
  GuidPrefix prefix = key.value_or(GuidPrefix{});
  if (forged) prefix[3] ^= 0x01;
  prefix[11] = tail;
  std::memcpy(data.m_guid.guidPrefix.value, prefix.data(), prefix.size());
  data.m_guid.entityId = rtps::c_EntityId_RTPSParticipant;
  data.identity_token_.properties().emplace_back("dds.cert.sn", subject);
  return data;
}

void discovered(
    DdsIdentities& identities, const rtps::ParticipantProxyData& data,
    rtps::ParticipantDiscoveryInfo::DISCOVERY_STATUS status = rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) {
  rtps::ParticipantDiscoveryInfo info(data);
  info.status = status;
  identities.on_participant_discovery(nullptr, std::move(info));
}

// The handle of writer `entity` of that participant, as SampleInfo::publication_handle gives it.
rtps::InstanceHandle_t writer_of(const rtps::ParticipantProxyData& data, uint8_t entity) {
  rtps::GUID_t guid = data.m_guid;
  guid.entityId.value[2] = entity;
  guid.entityId.value[3] = 0x02;  // a writer with key
  return rtps::InstanceHandle_t(guid);
}

TEST(DdsIdentities, OnASecuredLinkAParticipantSpeaksOnlyForTheSpaceItProved) {
  CapturedLog log;
  DdsIdentities identities(true);
  const auto kr = participant(subject_of("kr"), 1);
  const auto spy = participant(subject_of("spy"), 2);
  discovered(identities, kr);
  discovered(identities, spy);

  EXPECT_TRUE(identities.speaks_for(writer_of(kr, 1), "kr", "catalog entry", "diag"));
  EXPECT_TRUE(identities.speaks_for(writer_of(spy, 1), "spy", "catalog entry", "probe"));
  EXPECT_FALSE(identities.speaks_for(writer_of(spy, 1), "kr", "catalog entry", "diag"));
  EXPECT_FALSE(identities.speaks_for(writer_of(kr, 1), "jp", "context entry", "room.temperature"));

  EXPECT_EQ(log.count("a member proven as spy announced space kr's catalog entry kr/diag: ignored"), 1u) << log.text();
  EXPECT_EQ(log.count("a member proven as kr announced space jp's context entry jp/room.temperature: ignored"), 1u)
      << log.text();
}

TEST(DdsIdentities, ARefusalIsLoggedOncePerWriterAndSpace) {
  CapturedLog log;
  DdsIdentities identities(true);
  const auto spy = participant(subject_of("spy"), 2);
  discovered(identities, spy);

  for (int i = 0; i < 3; ++i) EXPECT_FALSE(identities.speaks_for(writer_of(spy, 1), "kr", "catalog entry", "diag"));
  EXPECT_FALSE(identities.speaks_for(writer_of(spy, 1), "jp", "catalog entry", "diag"));  // another space
  EXPECT_FALSE(identities.speaks_for(writer_of(spy, 2), "kr", "component state", "x"));   // another writer
  EXPECT_EQ(log.count("proven as spy announced space kr's"), 2u) << log.text();
  EXPECT_EQ(log.count("proven as spy announced space jp's"), 1u) << log.text();

  // Once the participant has left, a participant of the same prefix starts afresh.
  discovered(identities, spy, rtps::ParticipantDiscoveryInfo::REMOVED_PARTICIPANT);
  discovered(identities, spy);
  EXPECT_FALSE(identities.speaks_for(writer_of(spy, 1), "kr", "catalog entry", "diag"));
  EXPECT_EQ(log.count("proven as spy announced space kr's catalog entry"), 2u) << log.text();
}

TEST(DdsIdentities, OnASecuredLinkAParticipantThatProvedNothingSpeaksForNoSpace) {
  CapturedLog log;
  DdsIdentities identities(true);
  const auto forged = participant(subject_of("kr"), 3, /*forged=*/true);  // its GUID is not kr's
  const auto unknown = participant(subject_of("jp"), 4);                  // never discovered
  discovered(identities, forged);

  EXPECT_FALSE(identities.speaks_for(writer_of(forged, 1), "kr", "catalog entry", "diag"));
  EXPECT_FALSE(identities.speaks_for(writer_of(unknown, 1), "jp", "catalog entry", "diag"));
  EXPECT_EQ(log.count("a member proven as nothing (its space is not proven) announced space kr's"), 1u) << log.text();
  EXPECT_EQ(log.count("a member proven as nothing (its space is not proven) announced space jp's"), 1u) << log.text();
}

TEST(DdsIdentities, AProvenSpaceIsTakenFromThenOnAndToldOnce) {
  int told = 0;
  DdsIdentities identities(true, [&] { ++told; });
  const auto kr = participant(subject_of("kr"), 1);
  EXPECT_FALSE(identities.speaks_for(writer_of(kr, 1), "kr", "catalog entry", "diag"));  // not discovered yet
  discovered(identities, kr);
  EXPECT_EQ(told, 1);
  EXPECT_TRUE(identities.speaks_for(writer_of(kr, 1), "kr", "catalog entry", "diag"));
  discovered(identities, kr, rtps::ParticipantDiscoveryInfo::CHANGED_QOS_PARTICIPANT);  // nothing new proven
  EXPECT_EQ(told, 1);
}

// What a certificate proves is kept by its participant key: a participant gone (or dropped, and
// told so after it was found again) leaves samples that are still its space's, and a bridge
// restarted with the same certificate speaks for its space even before its discovery is told.
TEST(DdsIdentities, AProvenSpaceOutlivesItsParticipant) {
  int told = 0;
  DdsIdentities identities(true, [&] { ++told; });
  const auto kr = participant(subject_of("kr"), 1);
  discovered(identities, kr);
  discovered(identities, kr, rtps::ParticipantDiscoveryInfo::DROPPED_PARTICIPANT);
  EXPECT_TRUE(identities.speaks_for(writer_of(kr, 1), "kr", "catalog entry", "diag"));
  EXPECT_FALSE(identities.speaks_for(writer_of(kr, 1), "jp", "catalog entry", "diag"));

  const auto restarted = participant(subject_of("kr"), 7);  // the same certificate, another process
  EXPECT_TRUE(identities.speaks_for(writer_of(restarted, 1), "kr", "catalog entry", "diag"));
  EXPECT_EQ(identities.caller(writer_of(restarted, 1), "jp").space, "kr");
  discovered(identities, restarted);
  EXPECT_EQ(told, 1);  // nothing new was proven

  // A participant of another certificate proves nothing by it.
  const auto jp = participant(subject_of("jp"), 1);
  EXPECT_FALSE(identities.speaks_for(writer_of(jp, 1), "jp", "catalog entry", "diag"));
}

// The memory is bounded: subjects announced without end push the oldest out, not the process.
TEST(DdsIdentities, TheMemoryOfProvenSpacesIsBounded) {
  CapturedLog log;
  DdsIdentities identities(true);
  const auto first = participant(subject_of("first"), 1);
  discovered(identities, first);
  discovered(identities, first, rtps::ParticipantDiscoveryInfo::REMOVED_PARTICIPANT);
  for (int i = 0; i < 1024; ++i) {
    const auto other = participant(subject_of("s" + std::to_string(i)), 1);
    discovered(identities, other);
    discovered(identities, other, rtps::ParticipantDiscoveryInfo::REMOVED_PARTICIPANT);
  }
  EXPECT_FALSE(identities.speaks_for(writer_of(first, 1), "first", "catalog entry", "diag"));
  EXPECT_TRUE(identities.speaks_for(writer_of(participant(subject_of("s1023"), 1), 1), "s1023", "catalog entry", "x"));
}

TEST(DdsIdentities, OnAPlainLinkEverySampleIsTakenAsTheSpaceItNames) {
  CapturedLog log;
  int told = 0;
  DdsIdentities identities(false, [&] { ++told; });
  const auto spy = participant(subject_of("spy"), 2);
  discovered(identities, spy);
  EXPECT_TRUE(identities.speaks_for(writer_of(spy, 1), "kr", "catalog entry", "diag"));
  EXPECT_TRUE(identities.speaks_for(writer_of(spy, 1), "spy", "catalog entry", "diag"));
  EXPECT_EQ(told, 0);
  EXPECT_EQ(log.text(), "");
}

}  // namespace
}  // namespace urs::federation
