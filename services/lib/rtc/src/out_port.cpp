// OutPortBase (urs/rtc/data_port.hpp): one Link per connection, pushing each value to the
// connection's InPortCdr, in the calling thread (subscription flush) or a sender thread of its own
// (subscription new).
#include <spdlog/spdlog.h>

#include <condition_variable>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

#include "data_port_detail.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::rtc {

using data_port_detail::kInPortIor;
using data_port_detail::kInPortRef;
using data_port_detail::order_name;
using data_port_detail::setting;
using data_port_detail::worth_logging;

namespace {

const char* status_name(OpenRTM::PortStatus status) {
  switch (status) {
    case OpenRTM::PORT_OK:
      return "PORT_OK";
    case OpenRTM::PORT_ERROR:
      return "PORT_ERROR";
    case OpenRTM::BUFFER_FULL:
      return "BUFFER_FULL";
    case OpenRTM::BUFFER_EMPTY:
      return "BUFFER_EMPTY";
    case OpenRTM::BUFFER_TIMEOUT:
      return "BUFFER_TIMEOUT";
    case OpenRTM::UNKNOWN_ERROR:
      return "UNKNOWN_ERROR";
    default:
      return "?";
  }
}

}  // namespace

struct OutPortBase::Payload {
  explicit Payload(ByteOrder order) { stream.setByteSwapFlag(order == ByteOrder::kLittle); }

  cdrMemoryStream stream;
  OpenRTM::CdrData bytes;  // a view of stream's buffer, set once the value is in it
};

class OutPortBase::Link : public std::enable_shared_from_this<Link> {
 public:
  enum class Outcome { kDelivered, kRefused, kLost };

  Link(std::string port_name, std::string connector_id, OpenRTM::InPortCdr_ptr peer, Subscription subscription,
       ByteOrder order)
      : port_name_(std::move(port_name)),
        connector_id_(std::move(connector_id)),
        peer_(peer),
        subscription_(subscription),
        order_(order) {}

  const std::string& connector_id() const { return connector_id_; }
  Subscription subscription() const { return subscription_; }
  ByteOrder byte_order() const { return order_; }

  // Why the peer is taken for gone (its put raised a system exception); nullopt while it answers.
  std::optional<std::string> lost() const {
    std::lock_guard lock(mutex_);
    return lost_;
  }

  ConnectorStats stats() const {
    std::lock_guard lock(mutex_);
    return {connector_id_, subscription_, order_, sent_, refused_, skipped_, last_status_};
  }

  // One put() in the calling thread.
  Outcome put(const Payload& payload) {
    OpenRTM::PortStatus status = OpenRTM::UNKNOWN_ERROR;
    try {
      status = peer_->put(payload.bytes);
    } catch (const CORBA::SystemException& e) {
      std::lock_guard lock(mutex_);
      lost_ = describe(e);
      return Outcome::kLost;
    }
    std::lock_guard lock(mutex_);
    last_status_ = status;
    if (status == OpenRTM::PORT_OK) {
      ++sent_;
      return Outcome::kDelivered;
    }
    if (worth_logging(++refused_)) {
      spdlog::warn("port {}: connection {}: the InPort answered {} ({} refused so far)", port_name_, connector_id_,
                   status_name(status), refused_);
    }
    return Outcome::kRefused;
  }

  // subscription new: the sender thread puts the newest payload it was offered.
  void start_sender() {
    sender_ = std::thread([self = shared_from_this()] { self->send_newest(); });
  }
  void offer(std::shared_ptr<const Payload> payload) {
    {
      std::lock_guard lock(mutex_);
      if (pending_) ++skipped_;
      pending_ = std::move(payload);
    }
    wake_.notify_one();
  }
  // Ends the sender thread after the put in progress, if any.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
      pending_.reset();
    }
    wake_.notify_one();
    if (!sender_.joinable()) return;
    // A put can reach this very connection's teardown (an in-process InPort's callback
    // disconnecting it); the thread then finishes on its own, holding the link alive.
    if (sender_.get_id() == std::this_thread::get_id()) {
      sender_.detach();
    } else {
      sender_.join();
    }
  }

 private:
  void send_newest() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [&] { return stopping_ || pending_ != nullptr; });
      if (stopping_) return;
      const std::shared_ptr<const Payload> payload = std::move(pending_);
      pending_.reset();
      lock.unlock();
      put(*payload);
      lock.lock();
    }
  }

  const std::string port_name_;
  const std::string connector_id_;
  const OpenRTM::InPortCdr_var peer_;
  const Subscription subscription_;
  const ByteOrder order_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::uint64_t sent_ = 0;
  std::uint64_t refused_ = 0;
  std::uint64_t skipped_ = 0;
  OpenRTM::PortStatus last_status_ = OpenRTM::PORT_OK;
  std::optional<std::string> lost_;
  std::shared_ptr<const Payload> pending_;
  bool stopping_ = false;
  std::thread sender_;
};

OutPortBase::OutPortBase(std::string name, std::string data_type)
    : DataPort(std::move(name), "DataOutPort", std::move(data_type)) {}

OutPortBase::~OutPortBase() { detach(); }

std::vector<OutPortBase::ConnectorStats> OutPortBase::connector_stats() const {
  std::lock_guard lock(mutex_);
  std::vector<ConnectorStats> stats;
  for (const auto& [id, link] : links_) stats.push_back(link->stats());
  return stats;
}

OutPortBase::WriteResult OutPortBase::push(const std::function<void(cdrStream&)>& marshal) {
  std::vector<std::shared_ptr<Link>> links;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [id, link] : links_) links.push_back(link);
  }
  std::shared_ptr<Payload> payloads[2];  // little, big: each made when a connection first needs it
  const auto payload_in = [&](ByteOrder order) -> std::shared_ptr<const Payload> {
    std::shared_ptr<Payload>& payload = payloads[order == ByteOrder::kLittle ? 0 : 1];
    if (!payload) {
      payload = std::make_shared<Payload>(order);
      marshal(payload->stream);
      const CORBA::ULong size = payload->stream.bufSize();
      payload->bytes.replace(size, size, static_cast<CORBA::Octet*>(payload->stream.bufPtr()), false);
    }
    return payload;
  };

  WriteResult result;
  for (const auto& link : links) {
    if (link->lost()) continue;
    const std::shared_ptr<const Payload> payload = payload_in(link->byte_order());
    if (link->subscription() == Subscription::kNew) {
      link->offer(payload);
      ++result.delivered;
      continue;
    }
    switch (link->put(*payload)) {
      case Link::Outcome::kDelivered:
        ++result.delivered;
        break;
      case Link::Outcome::kRefused:
        ++result.refused;
        break;
      case Link::Outcome::kLost:
        break;
    }
  }
  for (const auto& link : links) {
    const auto reason = link->lost();
    if (!reason) continue;
    spdlog::warn("port {}: dropping connection {}: its InPort does not answer ({})", name(), link->connector_id(),
                 *reason);
    if (drop_connection(link->connector_id())) ++result.dropped;
  }
  return result;
}

std::optional<Subscription> OutPortBase::connector_subscription(const RTC::ConnectorProfile& profile) const {
  const std::string value = setting(profile, "dataport.subscription_type");
  const auto subscription = parse_subscription(value);
  if (!subscription) {
    spdlog::warn("port {}: connection {} refused: dataport.subscription_type={} is not supported (flush, new)", name(),
                 profile.connector_id.in(), value);
  }
  return subscription;
}

OpenRTM::InPortCdr_ptr OutPortBase::peer_of(const RTC::ConnectorProfile& profile) {
  CORBA::Object_var object = nv_object(profile.properties, kInPortRef);
  if (CORBA::is_nil(object)) {
    const auto ior = nv_string(profile.properties, kInPortIor);
    if (!ior) return OpenRTM::InPortCdr::_nil();
    try {
      object = orb().string_to_object(*ior);
    } catch (const std::invalid_argument& e) {
      spdlog::warn("port {}: connection {}: {}: {}", name(), profile.connector_id.in(), kInPortIor, e.what());
      return OpenRTM::InPortCdr::_nil();
    }
  }
  try {
    return OpenRTM::InPortCdr::_narrow(object);
  } catch (const CORBA::SystemException& e) {
    spdlog::warn("port {}: connection {}: the published InPortCdr does not answer: {}", name(),
                 profile.connector_id.in(), describe(e));
    return OpenRTM::InPortCdr::_nil();
  }
}

RTC::ReturnCode_t OutPortBase::publish_interfaces(RTC::ConnectorProfile& profile) {
  // Nothing to offer in push mode, but an unsuitable connector is refused before the InPort
  // publishes anything for it.
  if (!connector_byte_order(profile) || !connector_subscription(profile)) return RTC::BAD_PARAMETER;
  return RTC::RTC_OK;
}

RTC::ReturnCode_t OutPortBase::subscribe_interfaces(const RTC::ConnectorProfile& profile) {
  const auto order = connector_byte_order(profile);
  const auto subscription = connector_subscription(profile);
  if (!order || !subscription) return RTC::BAD_PARAMETER;
  const std::string id = profile.connector_id.in();
  OpenRTM::InPortCdr_var peer = peer_of(profile);
  if (CORBA::is_nil(peer)) {
    spdlog::warn("port {}: connection {} refused: no InPortCdr under {} or {}", name(), id, kInPortRef, kInPortIor);
    return RTC::RTC_ERROR;
  }
  auto link = std::make_shared<Link>(name(), id, peer._retn(), *subscription, *order);
  if (*subscription == Subscription::kNew) link->start_sender();
  std::shared_ptr<Link> replaced;
  {
    std::lock_guard lock(mutex_);
    replaced = std::exchange(links_[id], link);
  }
  if (replaced) replaced->stop();
  spdlog::debug("port {}: connection {} pushes {} ({}, {} endian)", name(), id, data_type(),
                *subscription == Subscription::kNew ? "new" : "flush", order_name(*order));
  return RTC::RTC_OK;
}

void OutPortBase::unsubscribe_interfaces(const RTC::ConnectorProfile& profile) {
  std::shared_ptr<Link> link;
  {
    std::lock_guard lock(mutex_);
    const auto it = links_.find(profile.connector_id.in());
    if (it == links_.end()) return;
    link = std::move(it->second);
    links_.erase(it);
  }
  link->stop();
}

}  // namespace urs::rtc
