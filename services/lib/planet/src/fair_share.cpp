#include "urs/planet/fair_share.hpp"

#include <stdexcept>

namespace urs::planet {

namespace {

std::string key_of(const ShareHolder& holder) { return (holder.privileged ? "p:" : "c:") + holder.credential; }

std::string n(uint64_t value) { return std::to_string(value); }

}  // namespace

void Refusals::count(const std::string& limit, uint64_t times) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [name, count] : counts_) {
    if (name == limit) {
      count += times;
      return;
    }
  }
  counts_.emplace_back(limit, times);
}

std::vector<std::pair<std::string, uint64_t>> Refusals::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counts_;
}

std::vector<std::pair<std::string, uint64_t>> FairShare::refusals() const {
  return {{limits_.per_credential_name, refused_per_credential_.load(std::memory_order_relaxed)},
          {limits_.total_name, refused_total_.load(std::memory_order_relaxed)}};
}

FairShare::FairShare(Limits limits) : limits_(std::move(limits)) {
  if (limits_.total == 0) throw std::invalid_argument(limits_.total_name + " must be at least 1");
  if (limits_.reserved >= limits_.total) {
    throw std::invalid_argument("the share kept for sam and operator sessions (" + limits_.reserved_name + ": " +
                                n(limits_.reserved) + ") must be below " + limits_.total_name + " (" +
                                n(limits_.total) + ")");
  }
}

FairShare::AccountPtr FairShare::account(const ShareHolder& holder) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto& slot = accounts_[key_of(holder)];
  if (!slot) slot.reset(new Account(holder));
  return slot;
}

bool FairShare::pool_full(bool privileged) const {
  const uint64_t in_pool = privileged ? used() : used_by_clients();
  return in_pool >= pool(privileged);
}

std::string FairShare::take(Account& account, uint64_t amount) {
  const bool privileged = account.privileged();
  const uint64_t mine = account.used();
  const uint64_t per_credential = limits_.per_credential == 0 ? limits_.total : limits_.per_credential;
  if (mine + amount > per_credential) {
    refused_per_credential_.fetch_add(1, std::memory_order_relaxed);
    return "credential '" + account.credential() + "' holds " + n(mine) + " " + limits_.what +
           (amount == 1 ? "" : " and asks for " + n(amount) + " more") + " (" + limits_.per_credential_name + " " +
           n(per_credential) + ")";
  }
  const uint64_t room = pool(privileged);
  const uint64_t in_pool = privileged ? used() : used_by_clients();
  if (in_pool + amount > room) {
    // The pool is full: only a credential within its fair share of it goes on.
    const uint64_t holders = (privileged ? active_.load() : active_clients_.load()) + (mine == 0 ? 1 : 0);
    const uint64_t fair = room / (holders == 0 ? 1 : holders);
    if (mine + amount > fair) {
      refused_total_.fetch_add(1, std::memory_order_relaxed);
      return "the server holds " + n(in_pool) + " " + limits_.what + (privileged ? "" : " for client credentials") +
             ", its limit (" + limits_.total_name + " " + n(limits_.total) +
             (privileged ? ""
                         : " less the " + n(limits_.reserved) + " kept for sam and operator sessions, " +
                               limits_.reserved_name) +
             "); credential '" + account.credential() + "' holds " + n(mine) + ", over its fair share of " + n(fair) +
             "; retry later";
    }
  }
  force(account, amount);
  return {};
}

void FairShare::force(Account& account, uint64_t amount) {
  if (amount == 0) return;
  const uint64_t before = account.used_.fetch_add(amount, std::memory_order_relaxed);
  added(account, before, amount);
}

void FairShare::added(Account& account, uint64_t before, uint64_t amount) {
  used_.fetch_add(amount, std::memory_order_relaxed);
  if (!account.privileged()) used_clients_.fetch_add(amount, std::memory_order_relaxed);
  if (before == 0) {
    active_.fetch_add(1);
    if (!account.privileged()) active_clients_.fetch_add(1);
  }
}

void FairShare::give(Account& account, uint64_t amount) {
  if (amount == 0) return;
  const uint64_t before = account.used_.fetch_sub(amount, std::memory_order_relaxed);
  used_.fetch_sub(amount, std::memory_order_relaxed);
  if (!account.privileged()) used_clients_.fetch_sub(amount, std::memory_order_relaxed);
  if (before == amount) {
    active_.fetch_sub(1);
    if (!account.privileged()) active_clients_.fetch_sub(1);
  }
}

std::string FairShare::take(const ShareHolder& holder, uint64_t amount) {
  AccountPtr held = account(holder);
  std::string refusal = take(*held, amount);
  if (!refusal.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = accounts_.find(key_of(holder));
    held.reset();
    if (it != accounts_.end() && it->second.use_count() == 1 && it->second->used() == 0) accounts_.erase(it);
  }
  return refusal;
}

void FairShare::give(const ShareHolder& holder, uint64_t amount) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = accounts_.find(key_of(holder));
  if (it == accounts_.end()) return;
  give(*it->second, amount);
  if (it->second.use_count() == 1 && it->second->used() == 0) accounts_.erase(it);
}

uint64_t FairShare::used_by(const std::string& credential) const {
  std::lock_guard<std::mutex> lock(mutex_);
  uint64_t total = 0;
  for (const char* prefix : {"c:", "p:"}) {
    auto it = accounts_.find(prefix + credential);
    if (it != accounts_.end()) total += it->second->used();
  }
  return total;
}

std::string FairShare::heaviest() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const Account* best = nullptr;
  for (const auto& [key, account] : accounts_) {
    if (account->used() == 0) continue;
    // A client credential is chosen before any privileged one.
    const bool better = best == nullptr || (best->privileged() && !account->privileged()) ||
                        (best->privileged() == account->privileged() && account->used() > best->used());
    if (better) best = account.get();
  }
  return best ? best->credential() : std::string();
}

std::vector<uint64_t> FairQueue::add(uint64_t key, const ShareHolder& holder) {
  std::vector<uint64_t> evicted;
  if (where_.count(key) != 0) return evicted;
  if (!share_.take(holder, 1).empty()) {
    evict_oldest_of(holder.credential, evicted);
    share_.force(*share_.account(holder), 1);
  }
  auto& mine = by_holder_[holder.credential];
  order_.push_back(key);
  mine.push_back(key);
  where_.emplace(key, Where{holder, std::prev(order_.end()), std::prev(mine.end())});
  while (share_.used() > share_.limits().total) {
    const std::string heaviest = share_.heaviest();
    if (heaviest.empty()) break;
    evict_oldest_of(heaviest, evicted);
  }
  return evicted;
}

void FairQueue::evict_oldest_of(const std::string& credential, std::vector<uint64_t>& evicted) {
  auto mine = by_holder_.find(credential);
  if (mine == by_holder_.end() || mine->second.empty()) return;
  const uint64_t key = mine->second.front();
  remove(key);
  evicted.push_back(key);
}

bool FairQueue::remove(uint64_t key) {
  auto it = where_.find(key);
  if (it == where_.end()) return false;
  order_.erase(it->second.overall);
  auto mine = by_holder_.find(it->second.holder.credential);
  mine->second.erase(it->second.mine);
  if (mine->second.empty()) by_holder_.erase(mine);
  share_.give(it->second.holder, 1);
  where_.erase(it);
  return true;
}

void FairQueue::touch(uint64_t key) {
  auto it = where_.find(key);
  if (it == where_.end()) return;
  order_.splice(order_.end(), order_, it->second.overall);
  auto& mine = by_holder_[it->second.holder.credential];
  mine.splice(mine.end(), mine, it->second.mine);
}

std::optional<uint64_t> FairQueue::oldest() const {
  if (order_.empty()) return std::nullopt;
  return order_.front();
}

}  // namespace urs::planet
