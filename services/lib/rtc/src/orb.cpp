#include "urs/rtc/orb.hpp"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "urs/rtc/trace_context.hpp"
#include "urs/util/cli.hpp"

namespace urs::rtc {
namespace {

// How long deactivate() waits for the calls in progress on an object to return.
constexpr std::chrono::seconds kReleaseWait{10};

}  // namespace

Orb::Orb(const OrbOptions& options) : max_calls_per_peer_(options.max_calls_per_peer) {
  if (options.max_calls_per_peer == 0 || options.max_calls_per_peer > kMaxCallsPerPeerLimit) {
    throw std::invalid_argument("max_calls_per_peer " + std::to_string(options.max_calls_per_peer) + " is outside 1.." +
                                std::to_string(kMaxCallsPerPeerLimit));
  }
  const std::string call_timeout = std::to_string(options.call_timeout.count());
  const std::string connect_timeout = std::to_string(options.connect_timeout.count());
  const std::string calls_per_peer = std::to_string(options.max_calls_per_peer);
  const char* table[6][2] = {};
  int n = 0;
  auto option = [&](const char* name, const char* value) {
    table[n][0] = name;
    table[n][1] = value;
    ++n;
  };
  if (!options.endpoint.empty()) option("endPoint", options.endpoint.c_str());
  option("clientCallTimeOutPeriod", call_timeout.c_str());
  if (options.connect_timeout.count() > 0) option("clientConnectTimeOutPeriod", connect_timeout.c_str());
  // Camera frames (921,600 bytes) and larger blobs travel as one GIOP message.
  option("giopMaxMsgSize", "67108864");
  // A deliberate bound on the calls in flight to one peer, not omniORB's default of 5 (OrbOptions).
  option("maxGIOPConnectionPerServer", calls_per_peer.c_str());
  int argc = 0;
  orb_ = CORBA::ORB_init(argc, nullptr, "omniORB4", table);
  install_trace_interceptors();  // every request carries the trace of the call it belongs to
  CORBA::Object_var object = orb_->resolve_initial_references("RootPOA");
  poa_ = PortableServer::POA::_narrow(object);
  PortableServer::POAManager_var manager = poa_->the_POAManager();
  manager->activate();
}

Orb::~Orb() {
  try {
    orb_->shutdown(true);
    orb_->destroy();
  } catch (const CORBA::Exception& e) {
    spdlog::warn("ORB shutdown: {}", describe(e));
  }
}

CORBA::Object_ptr Orb::activate(PortableServer::ServantBase* servant) {
  PortableServer::ObjectId_var id = poa_->activate_object(servant);
  // A DSI servant has no compiled-in type: omniORB's id_to_reference() would publish an empty
  // repository ID, so peers could neither narrow the reference without asking nor tell what it
  // is (catior, OpenRTM-aist's tools). Its _primary_interface() says what it is.
  if (auto* dynamic = dynamic_cast<PortableServer::DynamicImplementation*>(servant)) {
    CORBA::String_var type = dynamic->_primary_interface(id.in(), poa_.in());
    return poa_->create_reference_with_id(id.in(), type.in());
  }
  return poa_->id_to_reference(id.in());
}

void Orb::deactivate(PortableServer::ServantBase* servant) {
  // The POA holds a reference to an active servant and gives it back only once the calls in
  // progress on the object have returned (a reply may already be on its way to a peer that
  // answers us before the upcall's bookkeeping is done). Destroying the servant earlier
  // aborts the process, so this waits for that release.
  const CORBA::ULong held = servant->_refcount_value();
  try {
    PortableServer::ObjectId_var id = poa_->servant_to_id(servant);
    poa_->deactivate_object(id.in());
  } catch (const PortableServer::POA::ServantNotActive&) {
    return;
  } catch (const PortableServer::POA::ObjectNotActive&) {
    return;
  } catch (const PortableServer::POA::WrongPolicy&) {
    return;
  }
  const auto deadline = std::chrono::steady_clock::now() + kReleaseWait;
  while (servant->_refcount_value() >= held) {
    if (std::chrono::steady_clock::now() > deadline) {
      spdlog::warn("a deactivated object still has a call in progress after {} s", kReleaseWait.count());
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

std::string Orb::object_to_string(CORBA::Object_ptr object) const {
  CORBA::String_var text = orb_->object_to_string(object);
  return text.in();
}

CORBA::Object_ptr Orb::bounded(CORBA::Object_ptr object, std::chrono::milliseconds timeout) const {
  if (CORBA::is_nil(object)) return CORBA::Object::_nil();
  CORBA::Object_var own = fresh_reference(object);
  set_call_timeout(own, timeout);
  return own._retn();
}

CORBA::Object_ptr Orb::fresh_reference(CORBA::Object_ptr object) const {
  if (CORBA::is_nil(object)) throw std::invalid_argument("a bounded reference to a nil object");
  return string_to_object(object_to_string(object));
}

void Orb::set_call_timeout(CORBA::Object_ptr object, std::chrono::milliseconds timeout) {
  omniORB::setClientCallTimeout(object, static_cast<CORBA::ULong>(std::max<std::int64_t>(1, timeout.count())));
}

CORBA::Object_ptr Orb::string_to_object(const std::string& text) const {
  try {
    return orb_->string_to_object(text.c_str());
  } catch (const CORBA::Exception& e) {
    throw std::invalid_argument("not an object reference (" + describe(e) + "): " + text.substr(0, 40) +
                                (text.size() > 40 ? "..." : ""));
  }
}

std::string endpoint_from_address(const std::string& host_port, const std::string& what) {
  const util::Endpoint endpoint = util::parse_endpoint(host_port, what);
  return "giop:tcp:" + endpoint.host + ":" + std::to_string(endpoint.port);
}

std::string endpoint_towards(const std::string& peer, const std::string& what) {
  const util::Endpoint endpoint = util::parse_endpoint(peer, what);
  const auto fail = [&](const std::string& why) {
    return util::ConfigError(what + ": cannot tell which address of this host the peers of " + peer + " reach it by (" +
                             why + "); give --listen HOST:PORT");
  };
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int resolved = getaddrinfo(endpoint.host.c_str(), std::to_string(endpoint.port).c_str(), &hints, &found);
  if (resolved != 0) throw fail(std::string("cannot resolve ") + endpoint.host + ": " + gai_strerror(resolved));
  std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> addresses(found, freeaddrinfo);
  // connect() on a UDP socket only picks the route (and so the source address); nothing is sent.
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) throw fail(std::string("socket: ") + std::strerror(errno));
  sockaddr_in local{};
  socklen_t length = sizeof local;
  const bool routed = connect(fd, addresses->ai_addr, addresses->ai_addrlen) == 0 &&
                      getsockname(fd, reinterpret_cast<sockaddr*>(&local), &length) == 0;
  const int error = errno;
  close(fd);
  if (!routed) throw fail(std::string("no route: ") + std::strerror(error));
  char text[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &local.sin_addr, text, sizeof text);
  return "giop:tcp:" + std::string(text) + ":";
}

bool is_gone(CORBA::Object_ptr object) {
  if (CORBA::is_nil(object)) return true;
  try {
    return object->_non_existent();
  } catch (const CORBA::SystemException&) {
    return true;
  }
}

Liveness liveness(CORBA::Object_ptr object) {
  if (CORBA::is_nil(object)) return Liveness::kGone;
  try {
    return object->_non_existent() ? Liveness::kGone : Liveness::kAlive;
  } catch (const CORBA::TIMEOUT&) {
    return Liveness::kNoAnswer;
  } catch (const CORBA::TRANSIENT& e) {
    // A call that had to open a connection and timed out: something accepted it and kept quiet.
    return e.minor() == omni::TRANSIENT_CallTimedout ? Liveness::kNoAnswer : Liveness::kGone;
  } catch (const CORBA::SystemException&) {
    return Liveness::kGone;
  }
}

std::string describe(const CORBA::Exception& e) {
  if (const auto* system = CORBA::SystemException::_downcast(&e)) {
    const char* minor = system->NP_minorString();
    return std::string(system->_name()) + (minor ? std::string(" (") + minor + ")" : std::string());
  }
  return e._rep_id();
}

}  // namespace urs::rtc
