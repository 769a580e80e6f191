#pragma once
// Fair shares of one server budget (docs/planet.md §2, "Fair shares"): the one accounting rule
// behind every budget a peer can hold a share of — buffered bytes, sessions, retained closed
// sessions (urs::planet's server), pending calls, subscriptions, queued bus operations and
// publish de-duplication (the CAMUS server).
//
// A budget has a global limit (`total`), a limit per credential (`per_credential`: all the
// sessions of one credential together; per-session limits stay with the component that counts
// them) and a share of `total` held back (`reserved`) for privileged holders: sessions of role
// sam or operator and the server's own work. Client credentials together use at most
// total - reserved (their pool); privileged holders the whole of `total`.
//
// take(amount) admits when the holder stays within its per-credential limit and either its pool
// has room, or the pool is full and the holder is within its fair share of it (the pool divided
// by the credentials holding any of it, the asking one included). So a full pool refuses only a
// credential over its fair share, never one within it: the global limit may be passed by what
// credentials within their fair share take while others hold more than theirs (at most the
// pool once more, and less with per_credential below it). Refusals are texts naming the limit.
//
// Threading: thread-safe. take() and give() on an Account are lock-free (atomics; a check
// followed by an add may overshoot by what other threads add in between); the name-keyed calls
// take a mutex.

#include <atomic>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace urs::planet {

// How many times each limit refused something, by the limit's name (the option that sets it, e.g.
// "max_pending_calls_per_session"): what a server's metrics report as refusals by limit. The names
// come from the code, never from a peer, so there are few. Thread-safe; counting takes a mutex
// (refusals are rare).
class Refusals {
 public:
  void count(const std::string& limit, uint64_t times = 1);
  // Every limit counted so far (a limit appears once it refused once), by name.
  std::vector<std::pair<std::string, uint64_t>> snapshot() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, uint64_t>> counts_;
};

// Whose share something is counted in.
struct ShareHolder {
  std::string credential;   // the authenticated name (Identity::name), or the server's own name
  bool privileged = false;  // role sam or operator, or the server itself: may use the reserve
};

class FairShare {
 public:
  struct Limits {
    uint64_t total = 0;           // all holders together (must be > 0)
    uint64_t per_credential = 0;  // one credential (0 = total)
    uint64_t reserved = 0;        // of total, for privileged holders only (< total)
    std::string total_name;       // e.g. "max_pending_calls": named in refusals
    std::string per_credential_name;
    std::string reserved_name;  // how `reserved` is set, e.g. "reserved_percent 20"
    std::string what;           // what is counted, plural: "calls pending", "bytes", "subscriptions"
  };

  // One credential's use, shared by its sessions. Get it with account() and keep it while the
  // credential holds anything; take() and give() on it never lock.
  class Account {
   public:
    const std::string& credential() const { return holder_.credential; }
    bool privileged() const { return holder_.privileged; }
    uint64_t used() const { return used_.load(std::memory_order_relaxed); }

   private:
    friend class FairShare;
    explicit Account(ShareHolder holder) : holder_(std::move(holder)) {}
    const ShareHolder holder_;
    std::atomic<uint64_t> used_{0};
  };
  using AccountPtr = std::shared_ptr<Account>;

  // Throws std::invalid_argument if total is 0 or reserved is not below it.
  explicit FairShare(Limits limits);
  FairShare(const FairShare&) = delete;
  FairShare& operator=(const FairShare&) = delete;

  // The account of `holder.credential` (the same object for every caller while any holds it).
  // A credential is privileged in its account if the first holder to ask said so.
  AccountPtr account(const ShareHolder& holder);

  // Counts `amount` more for `account` and returns an empty string, or counts nothing and returns
  // why not: "credential 'x' holds N calls pending (max_pending_calls_per_credential M)", or for
  // a full pool "the server holds N calls pending for client credentials, its limit
  // (max_pending_calls T less the R kept for sam and operator sessions, reserved_percent P);
  // credential 'x' holds K, over its fair share of F; retry later".
  std::string take(Account& account, uint64_t amount);
  // Counts `amount` more whatever the limits (what a component cannot refuse: e.g. framing
  // overhead of a frame already admitted).
  void force(Account& account, uint64_t amount);
  void give(Account& account, uint64_t amount);

  // The same by name, for components that keep no Account (an account is made on first use and
  // dropped when its use falls to 0 and nobody else holds it).
  std::string take(const ShareHolder& holder, uint64_t amount);
  void give(const ShareHolder& holder, uint64_t amount);
  // What `credential` holds (in either role).
  uint64_t used_by(const std::string& credential) const;

  uint64_t used() const { return used_.load(std::memory_order_relaxed); }
  uint64_t used_by_clients() const { return used_clients_.load(std::memory_order_relaxed); }
  // Whether the pool of `privileged` holders is full (what must be given back first).
  bool pool_full(bool privileged) const;
  // The credential holding the most of the pool of client credentials (of all, if none of
  // theirs is held); empty when nothing is held. For budgets that make room by evicting: the
  // heaviest holder loses first.
  std::string heaviest() const;
  const Limits& limits() const { return limits_; }
  // The refusals of take(), by the limit that refused: per_credential_name, then total_name.
  std::vector<std::pair<std::string, uint64_t>> refusals() const;

 private:
  uint64_t pool(bool privileged) const { return privileged ? limits_.total : limits_.total - limits_.reserved; }
  void added(Account& account, uint64_t before, uint64_t amount);

  const Limits limits_;
  std::atomic<uint64_t> used_{0};
  std::atomic<uint64_t> used_clients_{0};
  std::atomic<uint64_t> active_{0};          // accounts holding anything
  std::atomic<uint64_t> active_clients_{0};  // of them, not privileged
  std::atomic<uint64_t> refused_per_credential_{0};
  std::atomic<uint64_t> refused_total_{0};
  mutable std::mutex mutex_;  // guards accounts_
  std::unordered_map<std::string, AccountPtr> accounts_;
};

// Keys held per credential, oldest first, bounded by fair shares of one count: adding a key
// over its credential's share (FairShare::take refused) evicts that credential's oldest key;
// adding one that takes the total over its limit evicts the oldest key of the heaviest
// credential. So what one credential adds never evicts another's while that one stays within its
// fair share. For what a server keeps on behalf of its peers and must forget to make room:
// resumable closed sessions, publish de-duplication.
//
// Threading: none; the owner locks.
class FairQueue {
 public:
  explicit FairQueue(FairShare::Limits limits) : share_(std::move(limits)) {}

  // Adds `key` (not yet held) as the newest of `holder`; returns the keys evicted to make room,
  // which are no longer held.
  std::vector<uint64_t> add(uint64_t key, const ShareHolder& holder);
  // Removes `key`; false if it was not held.
  bool remove(uint64_t key);
  // `key` becomes the newest of its credential and overall (least-recently-used order).
  void touch(uint64_t key);
  bool holds(uint64_t key) const { return where_.count(key) != 0; }
  // The oldest key overall.
  std::optional<uint64_t> oldest() const;
  size_t size() const { return where_.size(); }
  // Keys held for `credential` (either role).
  size_t held_by(const std::string& credential) const { return static_cast<size_t>(share_.used_by(credential)); }
  const FairShare& share() const { return share_; }

 private:
  struct Where {
    ShareHolder holder;
    std::list<uint64_t>::iterator overall;
    std::list<uint64_t>::iterator mine;
  };
  void evict_oldest_of(const std::string& credential, std::vector<uint64_t>& evicted);

  FairShare share_;
  std::list<uint64_t> order_;                                       // oldest first
  std::unordered_map<std::string, std::list<uint64_t>> by_holder_;  // by credential, oldest first
  std::unordered_map<uint64_t, Where> where_;
};

}  // namespace urs::planet
