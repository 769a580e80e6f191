#include "dds_identity.hpp"

#include <fastdds/rtps/common/InstanceHandle.h>
#include <fastdds/rtps/participant/ParticipantDiscoveryInfo.h>
#include <openssl/evp.h>
#include <openssl/objects.h>
#include <openssl/x509.h>
#include <spdlog/spdlog.h>

#include <cstring>
#include <memory>

namespace urs::federation {

namespace rtps = eprosima::fastrtps::rtps;

namespace {

using NamePtr = std::unique_ptr<X509_NAME, decltype(&X509_NAME_free)>;

// "/O=URSLink federation/CN=kr" as an X509_NAME (each value a UTF8String, as openssl req and
// deploy/pki.sh encode them), and its CN; nullptr if it is not of that form.
NamePtr parse_oneline(const std::string& subject, std::string& common_name) {
  NamePtr name(X509_NAME_new(), X509_NAME_free);
  if (subject.size() < 2 || subject[0] != '/') return NamePtr(nullptr, X509_NAME_free);
  for (unsigned char c : subject) {
    if (c < 0x20 || c > 0x7e || c == '\\') return NamePtr(nullptr, X509_NAME_free);  // escapes: not ours
  }
  std::size_t at = 1;
  while (at <= subject.size()) {
    std::size_t end = subject.find('/', at);
    if (end == std::string::npos) end = subject.size();
    const std::string part = subject.substr(at, end - at);
    const std::size_t equals = part.find('=');
    if (equals == std::string::npos || equals == 0) return NamePtr(nullptr, X509_NAME_free);
    const std::string key = part.substr(0, equals);
    const std::string value = part.substr(equals + 1);
    if (X509_NAME_add_entry_by_txt(name.get(), key.c_str(), MBSTRING_UTF8,
                                   reinterpret_cast<const unsigned char*>(value.c_str()), -1, -1, 0) != 1) {
      return NamePtr(nullptr, X509_NAME_free);
    }
    if (key == "CN") common_name = value;
    at = end + 1;
  }
  return name;
}

// The participant of a writer (an instance handle is its GUID: the participant's prefix first).
GuidPrefix participant_of(const rtps::InstanceHandle_t& writer) {
  GuidPrefix prefix{};
  std::memcpy(prefix.data(), writer.value, prefix.size());
  return prefix;
}

// The participant key of a prefix: its first 6 bytes, what PKI-DH derives from the subject.
std::array<uint8_t, 6> key_of(const GuidPrefix& prefix) {
  std::array<uint8_t, 6> key{};
  std::memcpy(key.data(), prefix.data(), key.size());
  return key;
}

}  // namespace

std::optional<GuidPrefix> participant_key_of(const std::string& subject, std::string* common_name) {
  std::string cn;
  NamePtr name = parse_oneline(subject, cn);
  if (!name || cn.empty()) return std::nullopt;
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (X509_NAME_digest(name.get(), EVP_sha256(), md, &length) != 1 || length < 6) return std::nullopt;
  // PKI-DH's participant key: a 1 bit, then the first 47 bits of the hash.
  GuidPrefix key{};
  key[0] = static_cast<uint8_t>(0x80 | (md[0] >> 1));
  for (std::size_t i = 1; i < 6; ++i) key[i] = static_cast<uint8_t>((md[i - 1] << 7) | (md[i] >> 1));
  if (common_name) *common_name = cn;
  return key;
}

std::optional<std::string> space_of_subject(const std::string& subject, const GuidPrefix& prefix) {
  std::string common_name;
  const std::optional<GuidPrefix> key = participant_key_of(subject, &common_name);
  if (!key || std::memcmp(key->data(), prefix.data(), 6) != 0) return std::nullopt;
  return common_name;
}

std::optional<std::string> DdsIdentities::remembered(const GuidPrefix& prefix) const {
  const auto known = spaces_.find(prefix);
  if (known != spaces_.end()) return known->second;
  const auto key = remembered_.find(key_of(prefix));
  if (key != remembered_.end()) return key->second;
  return std::nullopt;
}

void DdsIdentities::remember(const GuidPrefix& prefix, const std::string& space) {
  const std::array<uint8_t, 6> key = key_of(prefix);
  if (!remembered_.insert_or_assign(key, space).second) return;  // known already (the same space: the same hash)
  remembered_order_.push_back(key);
  if (remembered_order_.size() > kMaxRemembered) {
    remembered_.erase(remembered_order_.front());
    remembered_order_.pop_front();
  }
}

call::Identity DdsIdentities::caller(const rtps::InstanceHandle_t& writer, const std::string& declared_space) {
  if (!secured_) return {declared_space, "dds:" + declared_space, kDeclaredSpaceRole};
  const GuidPrefix prefix = participant_of(writer);
  std::lock_guard lock(mutex_);
  const std::optional<std::string> known = remembered(prefix);
  if (!known) return {declared_space, "dds:" + declared_space, kDeclaredSpaceRole};
  if (*known != declared_space && warned_.insert(prefix).second) {
    spdlog::warn(
        "dds: a participant whose certificate is space {} declares space {} in its requests; its calls "
        "are served as space {}'s",
        *known, declared_space, *known);
  }
  return {*known, "dds:" + *known, kVerifiedSpaceRole};
}

bool DdsIdentities::speaks_for(const rtps::InstanceHandle_t& writer, const std::string& space, const char* kind,
                               const std::string& name) {
  if (!secured_) return true;
  const GuidPrefix prefix = participant_of(writer);
  std::lock_guard lock(mutex_);
  const std::optional<std::string> known = remembered(prefix);
  if (known == space) return true;
  if (refused_[prefix].emplace(writer, space).second) {
    const std::string proven = known ? *known : "nothing (its space is not proven)";
    spdlog::warn(
        "dds: a member proven as {} announced space {}'s {} {}/{}: ignored (each space speaks only for "
        "itself)",
        proven, space, kind, space, name);
  }
  return false;
}

void DdsIdentities::on_participant_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                             rtps::ParticipantDiscoveryInfo&& info) {
  GuidPrefix prefix{};
  std::memcpy(prefix.data(), info.info.m_guid.guidPrefix.value, prefix.size());
  if (info.status == rtps::ParticipantDiscoveryInfo::REMOVED_PARTICIPANT ||
      info.status == rtps::ParticipantDiscoveryInfo::DROPPED_PARTICIPANT) {
    std::lock_guard lock(mutex_);
    spaces_.erase(prefix);
    warned_.erase(prefix);
    refused_.erase(prefix);
    return;
  }
  if (!secured_) return;
  std::string subject;
  for (const auto& property : info.info.identity_token_.properties()) {
    if (property.name() == "dds.cert.sn") subject = property.value();
  }
  const std::optional<std::string> space = space_of_subject(subject, prefix);
  bool proven = false;
  {
    std::lock_guard lock(mutex_);
    if (space) {
      proven = remembered(prefix) != space;
      spaces_.insert_or_assign(prefix, *space);
      remember(prefix, *space);
    } else {
      spaces_.erase(prefix);
    }
  }
  if (!space && subject.empty()) {
    // A participant without an identity (no security, or a handshake not begun): DDS-Security's
    // governance keeps it off every topic of the link, so nothing it writes arrives here.
    spdlog::warn(
        "dds: participant {} presents no certificate: it cannot authenticate, and the link's topics match "
        "none of its endpoints",
        info.info.m_participantName.to_string());
  } else if (!space) {
    spdlog::warn(
        "dds: participant {} announces subject '{}', which its GUID does not derive from: its requests "
        "prove no space (only the one they declare), and what it announces for any space is ignored",
        info.info.m_participantName.to_string(), subject);
  }
  if (proven && on_proven_) on_proven_();
}

}  // namespace urs::federation
