#pragma once
// What every `urs rtc` command shares: exit codes, the failure that ends a command, naming paths
// and PATH:PORT addresses, and a Session (the ORB and the naming client) that resolves them to
// components and ports, turning CORBA failures into one-line reasons. See docs/rtc.md.

#include <chrono>
#include <stdexcept>
#include <string>

#include "RTC.hh"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::cli::rtc_cli {

constexpr int kOk = 0;
constexpr int kFailed = 1;
constexpr int kUsage = 2;
constexpr int kUnreachable = 3;

// Ends one command (or, for act/deact/reset, one of its paths) with an exit code and a reason.
class Failure : public std::runtime_error {
 public:
  Failure(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

// Naming paths are written relative to the root; a leading or trailing '/' is tolerated.
std::string normalize_path(const std::string& text);

struct PortAddress {
  std::string path;
  std::string port;
};

// "PATH:PORT"; Failure(kUsage) otherwise.
PortAddress parse_port_address(const std::string& text);

// Why a call on a component failed: "unreachable (TRANSIENT ...)" for a component that does not
// answer (dead, hung or gone), else the exception's name. With `target` (the object called), a
// failure that looks like unreachability is checked with a bounded _non_existent() on it: a
// component that answers that it exists "reported an error (...)" (e.g. one of its ports could
// not reach a dead peer) instead of being called unreachable.
std::string reason(const CORBA::SystemException& e, CORBA::Object_ptr target = CORBA::Object::_nil());

// Runs calls on the component or port at `what` (the object `target`, if given), naming it in
// the failure.
template <class Body>
auto calling(const std::string& what, Body&& body, CORBA::Object_ptr target = CORBA::Object::_nil())
    -> decltype(body()) {
  try {
    return body();
  } catch (const CORBA::SystemException& e) {
    throw Failure(kFailed, what + ": " + reason(e, target));
  }
}

// "<instance>.<port>" without the instance, as ports are named within their component.
std::string short_port_name(const std::string& name);

class Session {
 public:
  Session(const std::string& naming, std::chrono::milliseconds call_timeout);

  rtc::NamingClient& naming() { return naming_; }
  rtc::Orb& orb() { return orb_; }

  // Failure(kFailed) for a path that is not bound; NamingUnreachable propagates.
  CORBA::Object_ptr resolve(const std::string& path);
  // ... and for an object that is no RT-Component or does not answer.
  RTC::RTObject_ptr component(const std::string& path);
  // ... and for a component without that port (the message lists its ports).
  RTC::PortService_ptr port(const PortAddress& address);

 private:
  rtc::Orb orb_;
  rtc::NamingClient naming_;
};

}  // namespace urs::cli::rtc_cli
