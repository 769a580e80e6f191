#pragma once
// Data ports (port.port_type DataOutPort / DataInPort) speaking OpenRTM-aist's CORBA_CDR push
// protocol, so either end may be an unmodified OpenRTM-aist port:
// - The InPort publishes one OpenRTM::InPortCdr object per connection, under
//   dataport.corba_cdr.inport_ior (stringified) and dataport.corba_cdr.inport_ref (the reference);
//   one object per connection is how it knows which connector's byte order a payload is in.
// - The OutPort takes that reference and calls put() with the raw CDR of one value: aligned from
//   offset 0, no encapsulation octet, in the byte order of dataport.serializer.cdr.endian.
// - Connector properties understood: dataport.interface_type=corba_cdr, dataflow_type=push,
//   subscription_type=flush|new, marshaling_type=cdr (or OpenRTM-aist Python's name, corba),
//   data_type (must name the port's type), serializer.cdr.endian. Anything else is refused with
//   BAD_PARAMETER and a log line naming the property.
// - A second connection between the same ports is refused unless
//   dataport.allow_dup_connection=YES (as for every port, urs/rtc/port.hpp).
// T is any omniidl-generated struct (RTC::TimedLong, RTC::CameraImage, ...); its TypeCode gives
// the port's dataport.data_type ("IDL:RTC/TimedLong:1.0").

#include <omniORB4/CORBA.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "DataPort.hh"
#include "urs/rtc/port.hpp"

namespace urs::rtc {

enum class ByteOrder { kLittle, kBig };
enum class Subscription {
  kFlush,  // put() in the writer's thread; write() returns the peer's answer
  kNew,    // a sender thread per connection puts the newest value; older unsent ones are skipped
};

// dataport.serializer.cdr.endian is a comma list whose first entry wins ("big,little" is big);
// empty means little. nullopt if the first entry is neither "little" nor "big".
std::optional<ByteOrder> parse_byte_order(const std::string& list);
// dataport.subscription_type; empty means flush. nullopt for anything else (periodic included).
std::optional<Subscription> parse_subscription(const std::string& text);
// Whether a connector's dataport.data_type names the type whose repository ID is given: the ID
// itself ("IDL:RTC/TimedLong:1.0"), or the bare type name OpenRTM-aist 1.x writes ("TimedLong").
bool data_type_matches(const std::string& repository_id, const std::string& connector_data_type);

// "IDL:RTC/TimedLong:1.0" for RTC::TimedLong: any struct omniidl compiled with its TypeCode.
template <typename T>
std::string repository_id() {
  CORBA::Any any;
  any <<= T();
  CORBA::TypeCode_var type = any.type();
  return type->id();
}

// What both kinds of data port share: the port properties and the connector checks.
class DataPort : public PortBase {
 public:
  const std::string& data_type() const { return data_type_; }

 protected:
  DataPort(std::string name, std::string port_type, std::string data_type);

  // The connector's byte order if this port can take part in it; nullopt (after a warning that
  // names the offending property) if it cannot.
  std::optional<ByteOrder> connector_byte_order(const RTC::ConnectorProfile& profile) const;

 private:
  const std::string data_type_;
};

// ---- out ----

class OutPortBase : public DataPort {
 public:
  // What one write() did, over all connections.
  struct WriteResult {
    std::size_t delivered = 0;  // flush: the peer answered PORT_OK; new: handed to the sender
    std::size_t refused = 0;    // flush: the peer answered another status (BUFFER_FULL, ...)
    std::size_t dropped = 0;    // connections dropped because their peer is gone
  };
  // One connection's record since it was made.
  struct ConnectorStats {
    std::string connector_id;
    Subscription subscription = Subscription::kFlush;
    ByteOrder byte_order = ByteOrder::kLittle;
    std::uint64_t sent = 0;     // put() answered PORT_OK
    std::uint64_t refused = 0;  // put() answered another status
    std::uint64_t skipped = 0;  // new: replaced by a newer value before it was sent
    OpenRTM::PortStatus last_status = OpenRTM::PORT_OK;
  };

  ~OutPortBase() override;  // disconnects and stops the sender threads
  std::vector<ConnectorStats> connector_stats() const;

 protected:
  OutPortBase(std::string name, std::string data_type);

  // Sends one value to every connection. `marshal` writes the value into a stream already set
  // to a byte order; it runs at most once per byte order the connections need.
  WriteResult push(const std::function<void(cdrStream&)>& marshal);

  RTC::ReturnCode_t publish_interfaces(RTC::ConnectorProfile& profile) override;
  RTC::ReturnCode_t subscribe_interfaces(const RTC::ConnectorProfile& profile) override;
  void unsubscribe_interfaces(const RTC::ConnectorProfile& profile) override;

 private:
  class Link;      // one connection: the peer's InPortCdr, its settings and counters
  struct Payload;  // one value marshalled in one byte order

  // The connection's subscription if this port can take part (a warning otherwise).
  std::optional<Subscription> connector_subscription(const RTC::ConnectorProfile& profile) const;
  OpenRTM::InPortCdr_ptr peer_of(const RTC::ConnectorProfile& profile);  // nil if none published

  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Link>> links_;  // by connector id
};

template <typename T>
class OutPort : public OutPortBase {
 public:
  explicit OutPort(std::string name) : OutPortBase(std::move(name), repository_id<T>()) {}

  // From any thread. A flush connection's put() runs in the caller's thread, so a slow or hung
  // peer delays write() by up to the ORB's call timeout; a new connection never does.
  WriteResult write(const T& value) {
    return push([&value](cdrStream& stream) { value >>= stream; });
  }
};

// ---- in ----

class InPortBase : public DataPort {
 public:
  std::uint64_t received() const { return received_; }        // values accepted
  std::uint64_t overwritten() const { return overwritten_; }  // unread values lost to a full buffer
  std::uint64_t rejected() const { return rejected_; }        // payloads answered PORT_ERROR
  std::size_t buffer_length() const { return buffer_length_; }

 protected:
  // Throws std::invalid_argument for a buffer_length of 0.
  InPortBase(std::string name, std::string data_type, std::size_t buffer_length);
  ~InPortBase() override;

  // Decodes one value from `stream` (throws CORBA::MARSHAL if it is short) and stores it.
  virtual void store(cdrMemoryStream& stream) = 0;
  // Throws std::length_error if bytes remain after the value: a payload is exactly one value.
  static void expect_end(cdrMemoryStream& stream);
  void count_received(bool overwrote_unread);
  void report_callback_error(const std::string& what) const;

  RTC::ReturnCode_t publish_interfaces(RTC::ConnectorProfile& profile) override;
  RTC::ReturnCode_t subscribe_interfaces(const RTC::ConnectorProfile& profile) override;
  void unsubscribe_interfaces(const RTC::ConnectorProfile& profile) override;
  void detaching() override;

 private:
  class Provider;  // the InPortCdr servant of one connection

  // Answers one put(): PORT_OK once stored, PORT_ERROR for a payload that is not one value.
  OpenRTM::PortStatus receive(const std::string& connector_id, ByteOrder order, const OpenRTM::CdrData& data);
  void retire(PortableServer::Servant_var<Provider> provider);

  const std::size_t buffer_length_;
  std::atomic<std::uint64_t> received_{0};
  std::atomic<std::uint64_t> overwritten_{0};
  std::atomic<std::uint64_t> rejected_{0};
  std::mutex mutex_;
  std::map<std::string, PortableServer::Servant_var<Provider>> providers_;  // by connector id
};

// Values wait in a ring of buffer_length; when it is full the oldest unread value is dropped
// (counted by overwritten()) and the writer still gets PORT_OK, so a slow reader sees the newest
// data rather than stalling or failing the writer (OpenRTM-aist's default answers BUFFER_FULL).
template <typename T>
class InPort : public InPortBase {
 public:
  explicit InPort(std::string name, std::size_t buffer_length = 64)
      : InPortBase(std::move(name), repository_id<T>(), buffer_length) {}
  // Disconnects first, so no put() reaches a half-destroyed port.
  ~InPort() override { detach(); }

  bool is_new() const {
    std::lock_guard lock(buffer_mutex_);
    return !unread_.empty();
  }
  std::size_t unread() const {
    std::lock_guard lock(buffer_mutex_);
    return unread_.size();
  }
  // The oldest unread value; false if there is none.
  bool read(T& value) {
    std::lock_guard lock(buffer_mutex_);
    if (unread_.empty()) return false;
    value = *unread_.front();
    unread_.pop_front();
    return true;
  }
  // The newest value received, read or not; nullopt before the first.
  std::optional<T> latest() const {
    std::lock_guard lock(buffer_mutex_);
    if (!latest_) return std::nullopt;
    return *latest_;
  }
  // Runs in the ORB's thread for each value as it is stored (puts of one connection one at a
  // time). It must not disconnect this port. An exception it throws is logged and ignored.
  void on_receive(std::function<void(const T&)> callback) {
    std::lock_guard lock(buffer_mutex_);
    callback_ = std::move(callback);
  }

 protected:
  void store(cdrMemoryStream& stream) override {
    auto value = std::make_shared<T>();
    *value <<= stream;
    expect_end(stream);
    bool overwrote = false;
    std::function<void(const T&)> callback;
    {
      std::lock_guard lock(buffer_mutex_);
      if (unread_.size() == buffer_length()) {
        unread_.pop_front();
        overwrote = true;
      }
      unread_.push_back(value);
      latest_ = value;
      callback = callback_;
    }
    count_received(overwrote);
    if (!callback) return;
    try {
      callback(*value);
    } catch (const std::exception& e) {
      report_callback_error(e.what());
    }
  }

 private:
  mutable std::mutex buffer_mutex_;
  std::deque<std::shared_ptr<const T>> unread_;
  std::shared_ptr<const T> latest_;
  std::function<void(const T&)> callback_;
};

}  // namespace urs::rtc
