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
// It also says whether a writer may speak for the space its samples name (speaks_for()): each
// space speaks only for itself, so on a secured link a catalog entry or a shared state sample is
// taken only from a participant that proved the very space it names.
//
// What a subject proves is a property of the certificate, not of one participant: the first 48 bits
// of the prefix are the subject's hash whichever process holds it. So a space, once proven, stays
// known by that participant key (a bounded memory) after its participant has gone: a bridge that
// restarts with the same certificate, or whose samples arrive before its discovery is reported, or
// after Fast DDS dropped it and found it again (discovery callbacks run on more than one thread, so
// a drop can be told after the new discovery), still speaks for its space. Only an authenticated
// participant's samples reach the link's topics, and authentication proves that very key.
//
// Threads: the listener runs on Fast DDS's discovery threads (and calls `on_proven` there);
// caller() and speaks_for() from any thread. Never blocks but on its own mutex, which is not held
// while `on_proven` runs.

#include <fastdds/rtps/common/InstanceHandle.h>

#include <array>
#include <cstdint>
#include <deque>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "urs/call/call.hpp"
#include "urs/federation/dds_link.hpp"  // kVerifiedSpaceRole, kDeclaredSpaceRole

namespace urs::federation {

using GuidPrefix = std::array<uint8_t, 12>;

// The space of `subject` (X509_NAME_oneline form, "/O=URSLink federation/CN=kr") if the first
// 48 bits of `prefix` are those PKI-DH derives from that subject; nullopt otherwise (or if the
// subject has no CN, or a character outside printable ASCII).
std::optional<std::string> space_of_subject(const std::string& subject, const GuidPrefix& prefix);
// The GUID prefix PKI-DH derives from `subject` (its first 6 bytes; the rest zero), and its CN
// into `common_name` if given; nullopt as space_of_subject().
std::optional<GuidPrefix> participant_key_of(const std::string& subject, std::string* common_name = nullptr);

class DdsIdentities : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  // `on_proven`: a participant has just proved its space (samples of its writers refused before,
  // because its discovery had not been seen yet, would now be taken: read them again). Must not block.
  explicit DdsIdentities(bool secured, std::function<void()> on_proven = {})
      : secured_(secured), on_proven_(std::move(on_proven)) {}

  // The caller of a request written by `writer` (SampleInfo::publication_handle) that declared
  // `declared_space`: {verified space, "dds:<space>", kVerifiedSpaceRole} when the writer's
  // participant proved its space, else {declared_space, "dds:<declared_space>", kDeclaredSpaceRole}.
  call::Identity caller(const eprosima::fastrtps::rtps::InstanceHandle_t& writer, const std::string& declared_space);

  // Whether a sample naming `space` written by `writer` (SampleInfo::publication_handle) is taken
  // as that space's: on a plain link always (nothing proves a writer's space there); on a secured
  // link only if the writer's participant proved `space`. Each refusal is logged once per (writer,
  // space) as a warning naming the space the writer proved and the sample, "<kind> <space>/<name>"
  // (e.g. "catalog entry kr/diag").
  bool speaks_for(const eprosima::fastrtps::rtps::InstanceHandle_t& writer, const std::string& space, const char* kind,
                  const std::string& name);

  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;

 private:
  const bool secured_;
  const std::function<void()> on_proven_;
  std::mutex mutex_;
  // The space of a participant key (the first 6 bytes of a prefix), as any participant proved it.
  std::optional<std::string> remembered(const GuidPrefix& prefix) const;  // mutex_ held
  void remember(const GuidPrefix& prefix, const std::string& space);      // mutex_ held

  std::map<GuidPrefix, std::string> spaces_;  // by participant GUID prefix: its verified space
  // By participant key: the space it proved, kept after its participants have left, oldest first
  // out beyond kMaxRemembered (announcing a subject costs a peer nothing, proving it a handshake).
  static constexpr std::size_t kMaxRemembered = 1024;
  std::map<std::array<uint8_t, 6>, std::string> remembered_;
  std::deque<std::array<uint8_t, 6>> remembered_order_;
  std::set<GuidPrefix> warned_;  // participants whose declared space differed, once each
  // By participant GUID prefix: its writers refused a space, and that space (logged once each).
  std::map<GuidPrefix, std::set<std::pair<eprosima::fastrtps::rtps::InstanceHandle_t, std::string>>> refused_;
};

// The instances of one keyed topic as a bridge takes them from a reader's cache read with any
// instance state: a sample, or an end (a dispose or an unregistration), counts only if `speaks_for`
// (e.g. DdsIdentities::speaks_for) lets its writer speak for the instance's space; another's is
// ignored and the instance kept as last taken, so that no member hides or replaces another space's
// entries. An instance of `own_space` is never another's business. Used by one thread at a time
// (its owner's lock).
template <class Sample>
class StandingInstances {
 public:
  struct Taken {
    Sample sample;                            // the last sample taken
    eprosima::fastdds::dds::SampleInfo info;  // its info (its writer: publication_handle)
    bool alive = true;                        // ended neither by its space nor by its writers' loss
  };
  // `speaks_for(info, sample, ending)`: whether the writer of `info` may write (or end) `sample`'s space.
  using SpeaksFor = std::function<bool(const eprosima::fastdds::dds::SampleInfo&, const Sample&, bool ending)>;

  // One read of the cache, in order; returns the instances it leaves.
  template <class Samples, class Infos>
  const std::map<eprosima::fastrtps::rtps::InstanceHandle_t, Taken>& read(const Samples& samples, const Infos& infos,
                                                                          const std::string& own_space,
                                                                          const SpeaksFor& speaks_for) {
    std::map<eprosima::fastrtps::rtps::InstanceHandle_t, Taken> now;
    for (decltype(samples.length()) i = 0; i < samples.length(); ++i) {
      const eprosima::fastdds::dds::SampleInfo& info = infos[i];
      const auto last = taken_.find(info.instance_handle);
      if (info.valid_data) {
        const Sample& sample = samples[i];
        if (sample.space() == own_space || speaks_for(info, sample, false)) {
          now[info.instance_handle] = {sample, info,
                                       info.instance_state == eprosima::fastdds::dds::ALIVE_INSTANCE_STATE};
        } else if (last != taken_.end()) {
          now.insert(*last);  // replaces nothing (and is refused, logged, by speaks_for)
        }
        continue;
      }
      auto seen = now.find(info.instance_handle);
      if (seen == now.end()) {
        if (last == taken_.end()) continue;  // nothing of it was taken
        seen = now.insert(*last).first;
      }
      const Sample& ended = seen->second.sample;
      seen->second.alive = ended.space() != own_space && !speaks_for(info, ended, true);
    }
    taken_ = std::move(now);
    return taken_;
  }

 private:
  std::map<eprosima::fastrtps::rtps::InstanceHandle_t, Taken> taken_;
};

}  // namespace urs::federation
