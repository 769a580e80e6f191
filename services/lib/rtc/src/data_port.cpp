#include "urs/rtc/data_port.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <condition_variable>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::rtc {
namespace {

constexpr const char* kInPortIor = "dataport.corba_cdr.inport_ior";
constexpr const char* kInPortRef = "dataport.corba_cdr.inport_ref";

std::string trimmed_lower(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  const auto last = text.find_last_not_of(" \t");
  std::string result = text.substr(first, last - first + 1);
  std::transform(result.begin(), result.end(), result.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return result;
}

// A connector property as OpenRTM-aist compares it: trimmed, lower case; "" if absent.
std::string setting(const RTC::ConnectorProfile& profile, const std::string& name) {
  return trimmed_lower(nv_string(profile.properties, name).value_or(""));
}

// A peer that misbehaves on every call would flood the log; the 1st, 10th, 100th... are enough
// to show that it goes on.
bool worth_logging(std::uint64_t count) {
  while (count >= 10 && count % 10 == 0) count /= 10;
  return count == 1;
}

const char* status_name(OpenRTM::PortStatus status) {
  switch (status) {
    case OpenRTM::PORT_OK: return "PORT_OK";
    case OpenRTM::PORT_ERROR: return "PORT_ERROR";
    case OpenRTM::BUFFER_FULL: return "BUFFER_FULL";
    case OpenRTM::BUFFER_EMPTY: return "BUFFER_EMPTY";
    case OpenRTM::BUFFER_TIMEOUT: return "BUFFER_TIMEOUT";
    case OpenRTM::UNKNOWN_ERROR: return "UNKNOWN_ERROR";
    default: return "?";
  }
}

const char* order_name(ByteOrder order) { return order == ByteOrder::kLittle ? "little" : "big"; }

}  // namespace

std::optional<ByteOrder> parse_byte_order(const std::string& list) {
  const std::string first = trimmed_lower(list.substr(0, list.find(',')));
  if (first.empty() || first == "little") return ByteOrder::kLittle;
  if (first == "big") return ByteOrder::kBig;
  return std::nullopt;
}

std::optional<Subscription> parse_subscription(const std::string& text) {
  const std::string value = trimmed_lower(text);
  if (value.empty() || value == "flush") return Subscription::kFlush;
  if (value == "new") return Subscription::kNew;
  return std::nullopt;
}

bool data_type_matches(const std::string& repository_id, const std::string& connector_data_type) {
  if (connector_data_type == repository_id) return true;
  // "IDL:RTC/TimedLong:1.0" -> "TimedLong"
  const auto version = repository_id.rfind(':');
  if (version == std::string::npos || version == 0) return false;
  const auto scope = repository_id.find_last_of("/:", version - 1);
  if (scope == std::string::npos) return false;
  return connector_data_type == repository_id.substr(scope + 1, version - scope - 1);
}

// ---- DataPort ----

DataPort::DataPort(std::string name, std::string port_type, std::string data_type)
    : PortBase(std::move(name), std::move(port_type)), data_type_(std::move(data_type)) {
  set_property("dataport.data_type", data_type_);
  set_property("dataport.interface_type", "corba_cdr");
  set_property("dataport.dataflow_type", "push");
  set_property("dataport.subscription_type", "flush,new");
}

std::optional<ByteOrder> DataPort::connector_byte_order(const RTC::ConnectorProfile& profile) const {
  const std::string id = profile.connector_id.in();
  const auto refuse = [&](const char* property, const std::string& value) -> std::optional<ByteOrder> {
    spdlog::warn("port {}: connection {} refused: {}={} is not supported", name(), id, property, value);
    return std::nullopt;
  };
  const std::pair<const char*, std::vector<std::string>> accepted[] = {
      {"dataport.interface_type", {"corba_cdr"}},
      {"dataport.dataflow_type", {"push"}},
      {"dataport.marshaling_type", {"cdr", "corba"}},
  };
  for (const auto& [property, values] : accepted) {
    const std::string value = setting(profile, property);
    if (!value.empty() && std::find(values.begin(), values.end(), value) == values.end()) {
      return refuse(property, value);
    }
  }
  const auto data_type = nv_string(profile.properties, "dataport.data_type");
  if (data_type && !data_type_matches(data_type_, *data_type)) {
    spdlog::warn("port {}: connection {} refused: dataport.data_type={} but this port carries {}", name(), id,
                 *data_type, data_type_);
    return std::nullopt;
  }
  const std::string endian = setting(profile, "dataport.serializer.cdr.endian");
  const auto order = parse_byte_order(endian);
  if (!order) return refuse("dataport.serializer.cdr.endian", endian);
  return order;
}

// ---- OutPort ----

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
      case Link::Outcome::kDelivered: ++result.delivered; break;
      case Link::Outcome::kRefused: ++result.refused; break;
      case Link::Outcome::kLost: break;
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
    spdlog::warn("port {}: connection {} refused: dataport.subscription_type={} is not supported (flush, new)",
                 name(), profile.connector_id.in(), value);
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

// ---- InPort ----

// put() calls for one connection are taken one at a time, which lets disconnect() wait for the
// one in progress: once it returns, nothing from this object reaches the port again.
class InPortBase::Provider : public POA_OpenRTM::InPortCdr {
 public:
  Provider(InPortBase& port, std::string connector_id, ByteOrder order)
      : port_(&port), connector_id_(std::move(connector_id)), order_(order) {}

  OpenRTM::PortStatus put(const OpenRTM::CdrData& data) override {
    std::lock_guard lock(mutex_);
    if (port_ == nullptr) return OpenRTM::PORT_ERROR;  // the connection ended while this call was on its way
    return port_->receive(connector_id_, order_, data);
  }

  void disconnect() {
    std::lock_guard lock(mutex_);
    port_ = nullptr;
  }

 private:
  std::mutex mutex_;
  InPortBase* port_;
  const std::string connector_id_;
  const ByteOrder order_;
};

InPortBase::InPortBase(std::string name, std::string data_type, std::size_t buffer_length)
    : DataPort(std::move(name), "DataInPort", std::move(data_type)), buffer_length_(buffer_length) {
  if (buffer_length_ == 0) throw std::invalid_argument("InPort " + short_name() + ": buffer length must be > 0");
}

InPortBase::~InPortBase() = default;

void InPortBase::expect_end(cdrMemoryStream& stream) {
  if (stream.checkInputOverrun(1, 1)) throw std::length_error("bytes follow the value");
}

void InPortBase::count_received(bool overwrote_unread) {
  ++received_;
  if (overwrote_unread && worth_logging(++overwritten_)) {
    spdlog::debug("port {}: buffer of {} full, the oldest unread value was dropped ({} so far)", name(),
                  buffer_length_, overwritten_.load());
  }
}

void InPortBase::report_callback_error(const std::string& what) const {
  spdlog::warn("port {}: the receive callback failed: {}", name(), what);
}

OpenRTM::PortStatus InPortBase::receive(const std::string& connector_id, ByteOrder order,
                                        const OpenRTM::CdrData& data) {
  const CORBA::ULong length = data.length();
  // omniORB aligns CDR by address, so the payload must start on an 8-byte boundary; an
  // in-process caller's buffer need not.
  std::vector<std::uint64_t> aligned;
  const CORBA::Octet* bytes = data.get_buffer();
  if (bytes == nullptr || reinterpret_cast<std::uintptr_t>(bytes) % alignof(std::uint64_t) != 0) {
    aligned.resize(length / sizeof(std::uint64_t) + 1);
    if (length > 0) std::memcpy(aligned.data(), bytes, length);
    bytes = reinterpret_cast<const CORBA::Octet*>(aligned.data());
  }
  cdrMemoryStream stream(const_cast<CORBA::Octet*>(bytes), length);
  stream.setByteSwapFlag(order == ByteOrder::kLittle);
  std::string problem;
  try {
    store(stream);
    return OpenRTM::PORT_OK;
  } catch (const CORBA::SystemException& e) {
    problem = describe(e);
  } catch (const std::exception& e) {
    problem = e.what();
  }
  if (worth_logging(++rejected_)) {
    spdlog::warn("port {}: connection {}: a payload of {} bytes is not one {} in {} endian: {} ({} rejected so far)",
                 name(), connector_id, length, data_type(), order_name(order), problem, rejected_.load());
  }
  return OpenRTM::PORT_ERROR;
}

void InPortBase::retire(PortableServer::Servant_var<Provider> provider) {
  provider->disconnect();
  orb().deactivate(provider.in());
}

RTC::ReturnCode_t InPortBase::publish_interfaces(RTC::ConnectorProfile& profile) {
  const auto order = connector_byte_order(profile);
  if (!order) return RTC::BAD_PARAMETER;
  const std::string id = profile.connector_id.in();
  PortableServer::Servant_var<Provider> provider = new Provider(*this, id, *order);
  CORBA::Object_var object = orb().activate(provider.in());
  nv_set(profile.properties, kInPortIor, orb().object_to_string(object));
  nv_set_object(profile.properties, kInPortRef, object);
  PortableServer::Servant_var<Provider> replaced;
  {
    std::lock_guard lock(mutex_);
    PortableServer::Servant_var<Provider>& slot = providers_[id];
    replaced = slot;
    slot = provider;
  }
  if (replaced.in() != nullptr) retire(replaced);
  spdlog::debug("port {}: connection {} receives {} in {} endian", name(), id, data_type(), order_name(*order));
  return RTC::RTC_OK;
}

RTC::ReturnCode_t InPortBase::subscribe_interfaces(const RTC::ConnectorProfile&) { return RTC::RTC_OK; }

void InPortBase::unsubscribe_interfaces(const RTC::ConnectorProfile& profile) {
  PortableServer::Servant_var<Provider> provider;
  {
    std::lock_guard lock(mutex_);
    const auto it = providers_.find(profile.connector_id.in());
    if (it == providers_.end()) return;
    provider = it->second;
    providers_.erase(it);
  }
  retire(provider);
}

void InPortBase::detaching() {
  std::map<std::string, PortableServer::Servant_var<Provider>> providers;
  {
    std::lock_guard lock(mutex_);
    providers.swap(providers_);
  }
  for (const auto& [id, provider] : providers) retire(provider);
}

}  // namespace urs::rtc
