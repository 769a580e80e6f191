#include "urs/bridge/core/bridge.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>
#include <optional>

#include "urs/bridge/core/call_meter.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge::core {

// A side and what the bridge keeps of it.
struct Bridge::Slot : SideEvents {
  Slot(Bridge& bridge, std::unique_ptr<Side> side) : bridge(bridge), side(std::move(side)) {}
  ~Slot() override { side.reset(); }  // before the flags its threads may still set

  // SideEvents
  void offers_changed() override {
    offers_dirty = true;
    bridge.signal();
  }
  void stand_ins_lost() override {
    stand_ins_dirty = true;
    bridge.signal();
  }
  void set_active(bool active) override { bridge.want_active(active); }
  void reopen() override {
    reopen_wanted = true;
    bridge.signal();
  }

  Bridge& bridge;
  std::unique_ptr<Side> side;
  // The bridge's thread only:
  bool open = false;
  Clock::time_point retry_at{};
  Clock::time_point poll_at{};
  std::string failure;  // why the last open() failed, logged once
  std::string failing;  // the same, under the bridge's mutex_ (status())
  // From any thread:
  std::atomic<bool> offers_dirty{false};
  std::atomic<bool> stand_ins_dirty{false};
  std::atomic<bool> reopen_wanted{false};
};

struct Bridge::Direction {
  DirectionConfig config;
  std::string name;
  Slot& from;
  Slot& to;
  std::unique_ptr<MeteredSource> source;    // `from`'s services, metered
  std::unique_ptr<RouteReconciler> routes;  // while both sides are open; swapped under mutex_
  Clock::time_point due{};
};

struct Bridge::Flow {
  bool state;  // else a stream
  Slot& from;
  Slot& to;
  bool wired = false;
};

Bridge::Bridge(std::string name, std::vector<std::unique_ptr<Side>> sides, BridgeLayout layout,
               const CallRecorders& calls)
    : name_(std::move(name)), open_retry_(layout.open_retry) {
  std::vector<std::string> errors;
  std::map<std::string, Slot*> by_name;
  for (auto& side : sides) {
    if (!side) continue;
    const std::string side_name = side->name();
    slots_.push_back(std::make_unique<Slot>(*this, std::move(side)));
    if (!by_name.emplace(side_name, slots_.back().get()).second)
      errors.push_back("side " + side_name + ": given twice");
  }
  auto find = [&](const std::string& side, const std::string& where) -> Slot* {
    const auto found = by_name.find(side);
    if (found == by_name.end()) errors.push_back(where + ": no side " + side + " is configured");
    return found == by_name.end() ? nullptr : found->second;
  };
  for (auto& config : layout.directions) {
    const std::string where = "direction " + config.from + " -> " + config.to;
    Slot* from = find(config.from, where);
    Slot* to = find(config.to, where);
    if (from != nullptr && from->side->services() == nullptr)
      errors.push_back(where + ": " + config.from + " offers no services");
    if (to != nullptr && to->side->offering() == nullptr)
      errors.push_back(where + ": " + config.to + " cannot stand for services");
    if (from == nullptr || to == nullptr) continue;
    std::string direction_name = config.from + " -> " + config.to;
    auto source =
        std::make_unique<MeteredSource>(*from->side->services(), direction_name, calls ? calls(config) : nullptr);
    directions_.push_back(std::make_unique<Direction>(
        Direction{std::move(config), std::move(direction_name), *from, *to, std::move(source), nullptr, {}}));
  }
  for (const auto& config : layout.state) {
    const std::string where = "state " + config.from + " -> " + config.to;
    Slot* from = find(config.from, where);
    Slot* to = find(config.to, where);
    if (from != nullptr && from->side->state_source() == nullptr)
      errors.push_back(where + ": " + config.from + " shares no state");
    if (to != nullptr && to->side->state_sink() == nullptr)
      errors.push_back(where + ": " + config.to + " takes no state");
    if (from != nullptr && to != nullptr) flows_.push_back(std::make_unique<Flow>(Flow{true, *from, *to}));
  }
  for (const auto& config : layout.streams) {
    const std::string where = "stream " + config.from + " -> " + config.to;
    Slot* from = find(config.from, where);
    Slot* to = find(config.to, where);
    if (from != nullptr && from->side->stream_source() == nullptr)
      errors.push_back(where + ": " + config.from + " has no streams");
    if (to != nullptr && to->side->stream_sink() == nullptr)
      errors.push_back(where + ": " + config.to + " takes no streams");
    if (from != nullptr && to != nullptr) flows_.push_back(std::make_unique<Flow>(Flow{false, *from, *to}));
  }
  if (!errors.empty()) {
    std::string text = "bridge " + name_ + ":";
    for (const auto& error : errors) text += "\n  " + error;
    throw util::ConfigError(text);
  }
}

Bridge::~Bridge() { shutdown(); }

void Bridge::start() {
  {
    std::lock_guard lock(mutex_);
    if (started_) return;
    started_ = true;
  }
  bool driven = false;
  for (auto& slot : slots_) {
    slot->side->start(*slot);
    driven = driven || slot->side->drives_activity();
  }
  if (!driven) want_active(true);
  thread_ = std::thread([this] { run(); });
}

void Bridge::shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  bool started = false;
  {
    std::lock_guard lock(mutex_);
    started = started_;
  }
  if (!started) return;
  for (auto it = slots_.rbegin(); it != slots_.rend(); ++it) (*it)->side->stop();
}

BridgeStatus Bridge::status() const {
  std::lock_guard lock(mutex_);
  BridgeStatus status;
  status.active = active_;
  for (const auto& slot : slots_) {
    if (slot->open) status.open.push_back(slot->side->name());
    if (!slot->open && !slot->failing.empty()) status.failing[slot->side->name()] = slot->failing;
  }
  for (const auto& direction : directions_) {
    DirectionStatus entry{direction->name, {}};
    if (direction->routes) entry.routes = direction->routes->routes();
    status.directions.push_back(std::move(entry));
  }
  return status;
}

std::vector<std::string> Bridge::sides() const {
  std::vector<std::string> names;
  for (const auto& slot : slots_) names.push_back(slot->side->name());
  return names;
}

Side* Bridge::side(const std::string& name) const {
  for (const auto& slot : slots_) {
    if (slot->side->name() == name) return slot->side.get();
  }
  return nullptr;
}

void Bridge::signal() {
  {
    std::lock_guard lock(mutex_);
    signalled_ = true;
  }
  wake_.notify_all();
}

void Bridge::want_active(bool active) {
  {
    std::lock_guard lock(mutex_);
    want_active_ = active;
  }
  wake_.notify_all();
}

Bridge::Clock::time_point Bridge::next_due() const {
  auto next = Clock::time_point::max();
  for (const auto& slot : slots_) next = std::min(next, slot->open ? slot->poll_at : slot->retry_at);
  for (const auto& direction : directions_) {
    if (direction->routes) next = std::min(next, direction->due);
  }
  return next;
}

void Bridge::run() {
  std::unique_lock lock(mutex_);
  while (true) {
    const bool want = want_active_ && !stopping_;
    if (want != active_) {
      lock.unlock();
      if (want) {
        activate(Clock::now());
      } else {
        deactivate();
      }
      lock.lock();
      continue;
    }
    if (stopping_) return;
    if (!active_) {
      wake_.wait(lock, [&] { return stopping_ || want_active_ != active_; });
      continue;
    }
    const auto next = next_due();
    const auto woken = [&] { return stopping_ || want_active_ != active_ || signalled_ || Clock::now() >= next; };
    if (next == Clock::time_point::max()) {
      wake_.wait(lock, woken);
    } else {
      wake_.wait_until(lock, next, woken);
    }
    signalled_ = false;
    if (stopping_ || want_active_ != active_) continue;
    lock.unlock();
    pass(Clock::now());
    lock.lock();
  }
}

void Bridge::activate(Clock::time_point now) {
  for (auto& slot : slots_) try_open(*slot, now);
  std::string open;
  for (const auto& slot : slots_) {
    if (slot->open) open += (open.empty() ? "" : ", ") + slot->side->name();
  }
  {
    std::lock_guard lock(mutex_);
    active_ = true;
  }
  spdlog::info("bridge {}: active (open: {})", name_, open.empty() ? "none" : open);
  pass(now);
}

void Bridge::deactivate() {
  {
    std::lock_guard lock(mutex_);
    active_ = false;
  }
  for (auto it = flows_.rbegin(); it != flows_.rend(); ++it) wire(**it, false);
  std::size_t withdrawn = 0;
  for (auto it = directions_.rbegin(); it != directions_.rend(); ++it) {
    std::unique_ptr<RouteReconciler> routes;
    {
      std::lock_guard lock(mutex_);
      routes.swap((*it)->routes);
    }
    if (!routes) continue;
    withdrawn += routes->routes().size();
    routes->withdraw_all();
  }
  for (auto it = slots_.rbegin(); it != slots_.rend(); ++it) {
    if ((*it)->open) close_side(**it);
  }
  spdlog::info("bridge {}: inactive; {} route(s) withdrawn", name_, withdrawn);
}

void Bridge::try_open(Slot& slot, Clock::time_point now) {
  try {
    slot.side->open();
  } catch (const std::exception& e) {
    if (e.what() != slot.failure) {
      spdlog::warn("bridge {}: side {}: {}; trying again every {:g} s", name_, slot.side->name(), e.what(),
                   std::chrono::duration<double>(open_retry_).count());
    }
    slot.failure = e.what();
    slot.retry_at = now + open_retry_;
    std::lock_guard lock(mutex_);
    slot.failing = slot.failure;
    return;
  }
  if (!slot.failure.empty()) spdlog::info("bridge {}: side {} is open", name_, slot.side->name());
  slot.failure.clear();
  std::lock_guard lock(mutex_);
  slot.failing.clear();
  slot.open = true;
  slot.poll_at = now;
}

void Bridge::wire(Flow& flow, bool on) {
  if (flow.wired == on) return;
  try {
    if (flow.state) {
      flow.from.side->state_source()->share_state(on ? flow.to.side->state_sink() : nullptr);
    } else {
      flow.from.side->stream_source()->stream_to(on ? flow.to.side->stream_sink() : nullptr);
    }
    flow.wired = on;
  } catch (const std::exception& e) {
    spdlog::error("bridge {}: {} {} -> {}: {}", name_, flow.state ? "state" : "stream", flow.from.side->name(),
                  flow.to.side->name(), e.what());
  }
}

void Bridge::close_side(Slot& slot) {
  for (auto& flow : flows_) {
    if (&flow->from == &slot || &flow->to == &slot) wire(*flow, false);
  }
  for (auto& direction : directions_) {
    if (&direction->from != &slot && &direction->to != &slot) continue;
    std::unique_ptr<RouteReconciler> routes;
    {
      std::lock_guard lock(mutex_);
      routes.swap(direction->routes);
    }
    if (routes) routes->withdraw_all();
  }
  try {
    slot.side->close();
  } catch (const std::exception& e) {
    spdlog::error("bridge {}: closing side {}: {}", name_, slot.side->name(), e.what());
  }
  std::lock_guard lock(mutex_);
  slot.open = false;
}

void Bridge::pass(Clock::time_point now) {
  for (auto& slot : slots_) {
    if (!slot->reopen_wanted.exchange(false) || !slot->open) continue;
    spdlog::warn("bridge {}: side {} is opened again", name_, slot->side->name());
    close_side(*slot);
    slot->retry_at = now;
  }
  for (auto& slot : slots_) {
    if (!slot->open && now >= slot->retry_at) try_open(*slot, now);
  }
  for (auto& slot : slots_) {
    if (!slot->open || now < slot->poll_at) continue;
    Clock::time_point next = now + open_retry_;
    try {
      next = slot->side->poll(now);
    } catch (const std::exception& e) {
      spdlog::error("bridge {}: side {}: {}", name_, slot->side->name(), e.what());
    }
    std::lock_guard lock(mutex_);
    slot->poll_at = next;
  }
  for (auto& flow : flows_) {
    if (flow->from.open && flow->to.open) wire(*flow, true);
  }
  for (auto& direction : directions_) {
    if (direction->routes || !direction->from.open || !direction->to.open) continue;
    auto routes = std::make_unique<RouteReconciler>(direction->name, direction->config.rules, *direction->source,
                                                    *direction->to.side->offering(), direction->config.retry,
                                                    direction->config.names);
    std::lock_guard lock(mutex_);
    direction->routes = std::move(routes);
    direction->due = now;
  }
  for (auto& slot : slots_) {
    const bool lost = slot->stand_ins_dirty.exchange(false);
    const bool changed = slot->offers_dirty.exchange(false);
    for (auto& direction : directions_) {
      if (!direction->routes) continue;
      if (lost && &direction->to == slot.get()) {
        direction->routes->target_restarted();
        direction->due = now;
      }
      if (changed && &direction->from == slot.get()) direction->due = now;
    }
  }
  // Each source's offers are read once per pass, for every direction from it that is due.
  std::map<const Slot*, std::optional<std::vector<Offer>>> read;
  for (auto& direction : directions_) {
    if (!direction->routes || now < direction->due) continue;
    auto known = read.find(&direction->from);
    if (known == read.end()) {
      std::optional<std::vector<Offer>> offers;
      try {
        offers = direction->from.side->services()->offers();
      } catch (const std::exception& e) {
        spdlog::error("bridge {}: the offers of side {}: {}", name_, direction->from.side->name(), e.what());
      }
      known = read.emplace(&direction->from, std::move(offers)).first;
    }
    if (known->second) {
      try {
        direction->routes->reconcile(*known->second, now);
      } catch (const std::exception& e) {
        spdlog::error("bridge {}: {}: {}", name_, direction->name, e.what());
      }
    }
    direction->due = now + direction->config.period;
  }
}

}  // namespace urs::bridge::core
