#pragma once
// DdsIdentities: which space each remote participant of the link is, as far as the link can prove
// it, and so the caller of each request read from one of its writers (docs/security.md, "Calls
// between spaces").
//
// On a secured link, Fast DDS's DDS:Auth:PKI-DH plugin verifies in each participant's handshake
// that its certificate was issued by the identity CA (not revoked by the CRL, within its validity),
// that it holds the certificate's key (signed challenge), and that the participant GUID it presents
// begins with a bit set to 1 followed by the first 47 bits of SHA-256 of the DER subject of that
// certificate (OMG DDS-Security 1.1, 9.3.2.5.2). This class takes the subject the participant
// announces in its identity token ("dds.cert.sn", X509_NAME_oneline form), hashes it the same way
// and accepts it only if the hash matches the participant's GUID prefix: the space is then the
// subject's CN. What it cannot prove is said in docs/security.md.
//
// On a plain link (or for a participant whose subject does not check out) the caller's space is
// only what its request declared.
//
// Threads: the listener runs on Fast DDS's discovery threads; caller() from any thread. Never
// blocks but on its own mutex.

#include <array>
#include <cstdint>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "urs/bridge/call_authorization.hpp"  // kVerifiedSpaceRole, kDeclaredSpaceRole
#include "urs/call/call.hpp"

namespace urs::bridge {

using GuidPrefix = std::array<uint8_t, 12>;

// The space of `subject` (X509_NAME_oneline form, "/O=URSLink federation/CN=kr") if the first
// 48 bits of `prefix` are those PKI-DH derives from that subject; nullopt otherwise (or if the
// subject has no CN, or a character outside printable ASCII).
std::optional<std::string> space_of_subject(const std::string& subject, const GuidPrefix& prefix);

class DdsIdentities : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  explicit DdsIdentities(bool secured) : secured_(secured) {}

  // The caller of a request written by `writer` (SampleInfo::publication_handle) that declared
  // `declared_space`: {verified space, "dds:<space>", kVerifiedSpaceRole} when the writer's
  // participant proved its space, else {declared_space, "dds:<declared_space>", kDeclaredSpaceRole}.
  call::Identity caller(const eprosima::fastrtps::rtps::InstanceHandle_t& writer,
                        const std::string& declared_space);

  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;

 private:
  const bool secured_;
  std::mutex mutex_;
  std::map<GuidPrefix, std::string> spaces_;  // by participant GUID prefix: its verified space
  std::set<GuidPrefix> warned_;               // participants whose declared space differed, once each
};

}  // namespace urs::bridge
