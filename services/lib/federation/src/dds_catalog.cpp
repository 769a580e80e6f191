#include "dds_catalog.hpp"

#include <spdlog/spdlog.h>

#include <cstring>
#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <stdexcept>

#include "Federation.h"
#include "dds_participant.hpp"
#include "dds_qos.hpp"
#include "dds_rpc.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;
using Clock = std::chrono::steady_clock;
using dds_rpc::bytes_of;
using dds_rpc::text_of;

DdsCatalog::DdsCatalog(const DdsOptions& options, LinkParticipant& participant, DdsIdentities& identities,
                       DdsLink::CatalogHandler on_catalog, std::function<void(const std::string& space)> on_space_lost)
    : options_(options),
      participant_(participant),
      identities_(identities),
      on_catalog_(std::move(on_catalog)),
      on_space_lost_(std::move(on_space_lost)) {}

void DdsCatalog::open(fdds::DataReaderListener* listener) {
  fdds::Topic* catalog_topic = participant_.topic(kCatalogTopic, participant_.entry_type);
  fdds::Topic* interface_topic = participant_.topic(kInterfaceTopic, participant_.interface_type);
  const fdds::DataWriterQos writer_qos = link_qos::keyed_state_writer(options_.lease);
  // In the shared topics' partitions (shared_partitions()): DDS refuses what the permissions do not grant.
  catalog_writer_ = create_shared_writer(participant_.shared_publisher(), catalog_topic, writer_qos, options_);
  // Descriptions: the same QoS, one instance per description. Fast DDS keeps two copies of each
  // sample a writer holds, so a description per service cost ~30 KiB per service.
  interface_writer_ = create_shared_writer(participant_.shared_publisher(), interface_topic, writer_qos, options_);
  // Entries end by a dispose and an unregistration (withdraw()); descriptions never do.
  catalog_reader_ = create_shared_reader(participant_.shared_subscriber(), catalog_topic,
                                         link_qos::ending_state_reader(options_.lease), listener, options_);
  interface_reader_ = create_shared_reader(participant_.shared_subscriber(), interface_topic,
                                           link_qos::keyed_state_reader(options_.lease), listener, options_);
  if (!catalog_writer_ || !catalog_reader_ || !interface_writer_ || !interface_reader_) {
    throw std::runtime_error("DDS: cannot create the catalog endpoints");
  }
  opened_ = true;
}

bool DdsCatalog::space_lost(const std::string& space) const {
  std::lock_guard lock(catalog_mutex_);
  bool seen = false;
  for (const auto& [writer, written] : writer_spaces_) {
    if (written != space) continue;
    if (!dead_writers_.count(writer)) return false;
    seen = true;
  }
  return seen;
}

std::optional<std::chrono::steady_clock::time_point> DdsCatalog::lost_since(const std::string& space) const {
  std::lock_guard lock(catalog_mutex_);
  const auto lost = lost_since_.find(space);
  if (lost == lost_since_.end()) return std::nullopt;
  return lost->second;
}

std::optional<std::chrono::system_clock::time_point> DdsCatalog::reached_since(const std::string& space) const {
  std::lock_guard lock(catalog_mutex_);
  const auto reached = reached_since_.find(space);
  if (reached == reached_since_.end()) return std::nullopt;
  return reached->second;
}

void DdsCatalog::reached(const std::string& space) const {
  lost_since_.erase(space);
  reached_since_.try_emplace(space, std::chrono::system_clock::now());
}

void DdsCatalog::writer_state(const fdds::InstanceHandle_t& writer, bool alive) {
  std::string lost;  // a space none of whose catalog writers is alive any more
  {
    std::lock_guard lock(catalog_mutex_);
    if (alive) {
      dead_writers_.erase(writer);
      const auto known = writer_spaces_.find(writer);
      if (known != writer_spaces_.end()) reached(known->second);
    } else {
      dead_writers_.insert(writer);
      auto it = writer_spaces_.find(writer);
      if (it != writer_spaces_.end()) {
        lost = it->second;
        for (const auto& [other, space] : writer_spaces_) {
          if (space == lost && !dead_writers_.count(other)) lost.clear();
        }
      }
    }
  }
  // Calls to a space whose bridges are all lost fail now, not when the participant lease ends.
  if (!lost.empty()) {
    {
      std::lock_guard lock(catalog_mutex_);
      lost_since_.try_emplace(lost, std::chrono::steady_clock::now());
      reached_since_.erase(lost);
    }
    on_space_lost_(lost);
  }
  on_catalog_();
}

void DdsCatalog::subscription_matched(const fdds::SubscriptionMatchedStatus& status) {
  if (status.current_count_change > 0) {  // a writer's handle is its GUID, its participant's prefix first
    const auto& own = participant_.participant()->guid().guidPrefix;
    if (std::memcmp(status.last_publication_handle.value, own.value, sizeof own.value) != 0) ++writers_matched_;
  }
  if (status.current_count_change != 0) writer_state(status.last_publication_handle, status.current_count_change > 0);
  if (status.current_count_change < 0) {
    std::lock_guard lock(catalog_mutex_);
    writer_spaces_.erase(status.last_publication_handle);
  }
}

void DdsCatalog::liveliness_changed(const fdds::LivelinessChangedStatus& status) {
  if (status.not_alive_count_change > 0) writer_state(status.last_publication_handle, false);
  if (status.alive_count_change > 0) writer_state(status.last_publication_handle, true);
}

std::vector<ServiceEntry> DdsCatalog::entries() const {
  std::set<fdds::InstanceHandle_t> dead;
  {
    std::lock_guard lock(catalog_mutex_);
    dead = dead_writers_;
  }
  std::vector<ServiceEntry> entries;
  // The descriptions known now (an entry whose description has not arrived yet is left out until
  // it has: its arrival wakes the bridge again). Content-addressed: a description is taken only
  // under its own digest; a sample under another's replaces nothing (the last taken is kept).
  std::map<std::string, std::string> descriptions;
  std::map<std::string, std::string> before;
  {
    std::lock_guard lock(catalog_mutex_);
    before = descriptions_;
  }
  std::vector<std::string> refused;
  fdds::LoanableSequence<dds::InterfaceDescription> described;
  fdds::SampleInfoSeq described_infos;
  // Any instance state: a description is its digest's content whoever wrote it and whether or
  // not its writer is alive (the entries' liveliness is the catalog's).
  if (interface_reader_->read(described, described_infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE,
                              fdds::ANY_VIEW_STATE, fdds::ANY_INSTANCE_STATE) == ReturnCode_t::RETCODE_OK) {
    for (fdds::LoanableCollection::size_type i = 0; i < described.length(); ++i) {
      if (!described_infos[i].valid_data) continue;
      const std::string& digest = described[i].digest();
      std::string text = text_of(described[i].descriptor_set());
      const auto kept = before.find(digest);
      // The bytes taken before under this digest were checked then: only other bytes are hashed.
      if ((kept != before.end() && kept->second == text) || description_digest(text) == digest) {
        descriptions[digest] = std::move(text);
      } else {
        refused.push_back(digest);
        if (kept != before.end()) descriptions.insert(*kept);
      }
    }
    interface_reader_->return_loan(described, described_infos);
  }
  {
    std::lock_guard lock(catalog_mutex_);
    descriptions_ = descriptions;
    for (const std::string& digest : refused) {
      if (refused_digests_.insert(digest).second) {
        spdlog::warn(
            "dds: a description written under digest {} is not the description of that digest (SHA-256 of "
            "its bytes): ignored",
            digest);
      }
    }
  }
  // Every instance, ended or not: each space speaks only for itself (StandingInstances), and a
  // writer refused a space neither offers its services nor keeps it alive (space_lost).
  fdds::LoanableSequence<dds::ServiceEntry> samples;
  fdds::SampleInfoSeq infos;
  if (catalog_reader_->read(samples, infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE, fdds::ANY_VIEW_STATE,
                            fdds::ANY_INSTANCE_STATE) != ReturnCode_t::RETCODE_OK) {
    return entries;
  }
  std::map<fdds::InstanceHandle_t, StandingInstances<dds::ServiceEntry>::Taken> now;
  {
    std::lock_guard lock(catalog_mutex_);
    now = held_.read(samples, infos, options_.space,
                     [this](const fdds::SampleInfo& info, const dds::ServiceEntry& sample, bool ending) {
                       return identities_.speaks_for(info.publication_handle, sample.space(),
                                                     ending ? "end of catalog entry" : "catalog entry", sample.name());
                     });
  }
  catalog_reader_->return_loan(samples, infos);
  std::map<fdds::InstanceHandle_t, std::string> spaces;
  for (const auto& [instance, held] : now) {
    const dds::ServiceEntry& sample = held.sample;
    if (!held.alive) continue;
    if (sample.space() == options_.space) continue;  // our own entries (or another's claiming ours)
    spaces[held.info.publication_handle] = sample.space();
    if (dead.count(held.info.publication_handle)) continue;
    const auto description = descriptions.find(sample.interface_digest());
    if (description == descriptions.end()) continue;
    entries.push_back({sample.space(), sample.name(), sample.interface_name(), sample.repository_id(), sample.origin(),
                       sample.bridge(), sample.deadline_ms(), description->second});
  }
  {
    std::lock_guard lock(catalog_mutex_);
    for (auto& [writer, space] : spaces) {
      if (!dead.count(writer)) reached(space);  // one of its writers is alive: the space is back, or new
      writer_spaces_[writer] = std::move(space);
    }
  }
  return entries;
}

void DdsCatalog::announce(const ServiceEntry& entry) {
  dds::ServiceEntry sample;
  sample.space(options_.space);
  sample.name(entry.name);
  sample.interface_name(entry.interface_name);
  sample.repository_id(entry.repository_id);
  sample.origin(entry.origin);
  sample.bridge(options_.bridge);
  sample.deadline_ms(entry.deadline_ms);
  sample.interface_digest(description_digest(entry.descriptor_set));
  {
    // Each description before the first entry naming it (readers skip entries whose description
    // they lack, so the order only saves a wake-up), and again once a lease with the entries'
    // re-announcement: a reader that lost this writer (a cut network) and matches it again would
    // drop the samples it had already seen, so only new ones reach it.
    std::lock_guard lock(interfaces_mutex_);
    const auto now = Clock::now();
    auto [written, first] = interfaces_written_.try_emplace(sample.interface_digest(), now);
    if (first || now - written->second >= options_.lease) {
      written->second = now;
      dds::InterfaceDescription description;
      description.digest(sample.interface_digest());
      description.descriptor_set(bytes_of(entry.descriptor_set));
      if (!interface_writer_->write(&description)) {
        spdlog::warn("dds: the description of {} could not be written", entry.interface_name);
        interfaces_written_.erase(sample.interface_digest());
      }
    }
  }
  if (!catalog_writer_->write(&sample)) spdlog::warn("dds: announcing {} failed", entry.name);
}

void DdsCatalog::withdraw(const std::string& name) {
  dds::ServiceEntry sample;
  sample.space(options_.space);
  sample.name(name);
  // By key (HANDLE_NIL): Fast DDS 2.9's lookup_instance() finds no instance that write() made, so
  // a withdrawal looked up first was never sent. An entry never announced is refused, harmlessly.
  catalog_writer_->dispose(&sample, fdds::HANDLE_NIL);
  catalog_writer_->unregister_instance(&sample, fdds::HANDLE_NIL);
}

}  // namespace urs::federation
