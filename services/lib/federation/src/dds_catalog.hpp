#pragma once
// DdsCatalog (internal to urs::bridge): the DdsLink's catalog. Announces and withdraws this
// space's services on urs/catalog, each naming its interface's description, written once per
// digest (and again once a lease) on urs/interface; reads the other spaces' entries from its
// readers' caches, joined with the descriptions by digest; follows the catalog writers' matches and
// liveliness, so that a space whose bridges are all lost is known (space_lost) and its entries
// left out. An entry is taken only from a writer that may speak for the space it names
// (DdsIdentities::speaks_for: on a secured link, the space its participant proved).
//
// Threads: announce(), withdraw(), entries() and space_lost() from any thread; subscription_matched()
// and liveliness_changed() on DDS listener threads (they call the handlers there, which must not
// block). Its locks are never held while a handler or Fast DDS runs, but for the writes of
// announce().

#include <atomic>
#include <chrono>
#include <fastdds/dds/common/InstanceHandle.hpp>
#include <fastdds/dds/core/status/LivelinessChangedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "Federation.h"
#include "dds_identity.hpp"
#include "dds_participant.hpp"
#include "urs/federation/dds_link.hpp"

namespace urs::federation {

class DdsCatalog {
 public:
  static constexpr const char* kCatalogTopic = "urs/catalog";
  static constexpr const char* kInterfaceTopic = "urs/interface";

  // `on_catalog`: the other spaces' catalog changed (DdsLink::CatalogHandler). `on_space_lost`:
  // every catalog writer of that space lost its liveliness (its calls in flight fail now).
  // `identities` outlives this.
  DdsCatalog(const DdsOptions& options, LinkParticipant& participant, DdsIdentities& identities,
             DdsLink::CatalogHandler on_catalog, std::function<void(const std::string& space)> on_space_lost);
  DdsCatalog(const DdsCatalog&) = delete;
  DdsCatalog& operator=(const DdsCatalog&) = delete;

  // Creates the writers and readers (the readers with `listener`, which hands their events back
  // here); throws std::runtime_error if DDS refuses.
  void open(eprosima::fastdds::dds::DataReaderListener* listener);
  // The writers whose liveliness the link asserts.
  std::vector<eprosima::fastdds::dds::DataWriter*> writers() const { return {catalog_writer_, interface_writer_}; }

  void announce(const ServiceEntry& entry);
  void withdraw(const std::string& name);
  // DdsLink::catalog().
  std::vector<ServiceEntry> entries() const;
  // True if catalog writers of `space` were seen and every one has lost its liveliness.
  bool space_lost(const std::string& space) const;
  // Since when every catalog writer of `space` has been lost (their liveliness, or their match: a
  // bridge killed, paused, cut off or stopped), until one of that space's is alive again; nullopt
  // for a space that was never lost, or is back.
  std::optional<std::chrono::steady_clock::time_point> lost_since(const std::string& space) const;
  // Since when `space` has been reached: a catalog writer of it read alive, none lost since (all of
  // them lost ends it); nullopt if it is not reached now.
  std::optional<std::chrono::system_clock::time_point> reached_since(const std::string& space) const;

  // DdsLink::catalog_writers_matched().
  uint64_t writers_matched() const { return writers_matched_; }

  // From the readers' listener (urs/catalog only).
  void subscription_matched(const eprosima::fastdds::dds::SubscriptionMatchedStatus& status);
  void liveliness_changed(const eprosima::fastdds::dds::LivelinessChangedStatus& status);
  void changed() const { on_catalog_(); }  // data arrived on urs/catalog or urs/interface
  // A participant proved its space (DdsIdentities): its entries refused until now are taken at the
  // next read. Tells the handler once the readers exist (before, nothing was read).
  void proven() const {
    if (opened_) on_catalog_();
  }

 private:
  void writer_state(const eprosima::fastdds::dds::InstanceHandle_t& writer, bool alive);

  const DdsOptions& options_;
  LinkParticipant& participant_;
  DdsIdentities& identities_;
  const DdsLink::CatalogHandler on_catalog_;
  const std::function<void(const std::string&)> on_space_lost_;
  eprosima::fastdds::dds::DataWriter* catalog_writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* catalog_reader_ = nullptr;
  eprosima::fastdds::dds::DataWriter* interface_writer_ = nullptr;
  eprosima::fastdds::dds::DataReader* interface_reader_ = nullptr;
  std::atomic<bool> opened_{false};  // open() has made the endpoints

  std::mutex interfaces_mutex_;
  std::map<std::string, std::chrono::steady_clock::time_point> interfaces_written_;  // digest -> when last written

  std::atomic<uint64_t> writers_matched_{0};  // other participants' catalog writers matched so far
  // Guards dead_writers_, writer_spaces_, lost_since_, reached_since_, held_, refused_digests_ and descriptions_.
  mutable std::mutex catalog_mutex_;
  std::set<eprosima::fastdds::dds::InstanceHandle_t> dead_writers_;  // catalog writers whose liveliness is lost
  // Catalog writers seen, by space written (filled by entries(); a writer refused that space is not).
  mutable std::map<eprosima::fastdds::dds::InstanceHandle_t, std::string> writer_spaces_;
  // The spaces all of whose catalog writers are lost, and since when (lost_since()).
  mutable std::map<std::string, std::chrono::steady_clock::time_point> lost_since_;
  // The spaces reached, and since when (reached_since()).
  mutable std::map<std::string, std::chrono::system_clock::time_point> reached_since_;
  // `space` has a catalog writer alive: it is back if it was lost, reached from now if it was not.
  void reached(const std::string& space) const;    // catalog_mutex_ held
  mutable std::set<std::string> refused_digests_;  // descriptions not matching their digest (logged once each)
  mutable std::map<std::string, std::string> descriptions_;  // by digest: those entries() took last
  // The entries entries() read last (what an ignored end or sample keeps).
  mutable StandingInstances<dds::ServiceEntry> held_;
};

}  // namespace urs::federation
