// InPortBase (urs/rtc/data_port.hpp): one InPortCdr servant (Provider) per connection, published
// in the connector profile; each put() decoded in the connection's byte order into the port.
#include <spdlog/spdlog.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "data_port_detail.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::rtc {

using data_port_detail::kInPortIor;
using data_port_detail::kInPortRef;
using data_port_detail::order_name;
using data_port_detail::worth_logging;

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
    spdlog::debug("port {}: buffer of {} full, the oldest unread value was dropped ({} so far)", name(), buffer_length_,
                  overwritten_.load());
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
