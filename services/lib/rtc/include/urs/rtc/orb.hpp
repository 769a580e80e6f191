#pragma once
// The process's one omniORB ORB and its root POA, started with the options URSLink's RT side
// needs: where to listen (or an ephemeral port), the client call timeout, the address published
// in object references. omniORB serves requests on its own thread pool once the POA manager is
// active; no thread has to sit in ORB::run().

#include <omniORB4/CORBA.h>

#include <chrono>
#include <string>

namespace urs::rtc {

// How many calls a process sends at once to one peer process unless told otherwise (--max-calls-per-peer):
// the calls a bridge runs at once towards RT providers, `workers` (16) from each of its CAMUS and DDS sides.
inline constexpr unsigned kDefaultMaxCallsPerPeer = 32;
inline constexpr unsigned kMaxCallsPerPeerLimit = 1024;  // the largest --max-calls-per-peer accepted

struct OrbOptions {
  // giop:tcp:<host>:<port> to listen on; empty lets omniORB choose (all interfaces, ephemeral port).
  std::string endpoint;
  // Bound on every outgoing call (OpenRTM-aist's default is 10 s). 0 leaves calls unbounded.
  std::chrono::milliseconds call_timeout{10000};
  // Bound on establishing a connection to a peer that does not answer (0: omniORB's default).
  std::chrono::milliseconds connect_timeout{2000};
  // Calls in flight at once from this process to one peer process (an RT provider's manager, the
  // naming service), each on a connection of its own: omniORB sends one call per connection at a
  // time and opens at most this many connections to a peer (its maxGIOPConnectionPerServer, which
  // is 5 unless set). A call beyond it waits for one of those calls to return, within its own
  // call timeout; past that it fails with CORBA::TIMEOUT, COMPLETED_NO (it was never sent).
  // 1..kMaxCallsPerPeerLimit.
  unsigned max_calls_per_peer = kDefaultMaxCallsPerPeer;
};

class Orb {
 public:
  // Throws std::invalid_argument if options.max_calls_per_peer is outside 1..kMaxCallsPerPeerLimit.
  explicit Orb(const OrbOptions& options = {});
  ~Orb();  // shuts the ORB down and destroys it (waits for calls in progress)
  Orb(const Orb&) = delete;
  Orb& operator=(const Orb&) = delete;

  CORBA::ORB_ptr orb() const { return orb_.in(); }
  unsigned max_calls_per_peer() const { return max_calls_per_peer_; }
  PortableServer::POA_ptr poa() const { return poa_.in(); }

  // Activates `servant` in the root POA; the returned reference is owned by the caller and
  // carries the servant's repository ID (a DSI servant's _primary_interface()).
  CORBA::Object_ptr activate(PortableServer::ServantBase* servant);
  // Deactivates the servant's object (no-op if it is not active) and returns once the calls in
  // progress on it have returned, so that the servant may be destroyed. Never call it for a
  // servant from inside a call on that same servant (it would wait for itself, then give up).
  void deactivate(PortableServer::ServantBase* servant);

  std::string object_to_string(CORBA::Object_ptr object) const;
  // A reference of the caller's own to `object` whose calls give up after `timeout` (other
  // references to the object keep their bounds). Opening a new connection is still bounded by
  // the ORB's connect timeout. Caller owns; nil for nil.
  CORBA::Object_ptr bounded(CORBA::Object_ptr object, std::chrono::milliseconds timeout) const;
  // A new reference of IDL type T to `object` whose calls wait at most `timeout` (no remote
  // call: the caller knows the type). omniORB keeps a call timeout per reference object, and
  // _duplicate() shares the object, so a bound set on a duplicate is overwritten by the next one
  // set on the original (or on another duplicate); this reference is made anew from the IOR and
  // no other setting touches it. Throws std::invalid_argument for nil.
  template <typename T>
  typename T::_var_type bounded(CORBA::Object_ptr object, std::chrono::milliseconds timeout) const {
    CORBA::Object_var fresh = fresh_reference(object);
    typename T::_var_type typed = T::_unchecked_narrow(fresh);
    set_call_timeout(typed, timeout);
    return typed;
  }
  // Throws std::invalid_argument with omniORB's reason for a malformed IOR or corbaloc URL.
  CORBA::Object_ptr string_to_object(const std::string& text) const;

 private:
  CORBA::Object_ptr fresh_reference(CORBA::Object_ptr object) const;  // caller owns
  static void set_call_timeout(CORBA::Object_ptr object, std::chrono::milliseconds timeout);

  unsigned max_calls_per_peer_;
  CORBA::ORB_var orb_;
  PortableServer::POA_var poa_;
};

// "giop:tcp:<host>:<port>" from "HOST:PORT" (as given to --listen); throws urs::util::ConfigError.
std::string endpoint_from_address(const std::string& host_port, const std::string& what);

// The endpoint to use when no --listen is given: "giop:tcp:<address>:" (an ephemeral port) on the
// address of this host that the route to `peer` ("HOST:PORT", the naming service) leaves from,
// so every object reference carries an address the peers of that service reach: 127.0.0.1 when
// it is on loopback, the interface towards it otherwise. (Left to itself omniORB publishes the
// first non-loopback address, which may be on a network those peers do not reach.) Sends
// nothing. Throws urs::util::ConfigError naming `what`, the peer and the reason if there is no
// such route or the name does not resolve.
std::string endpoint_towards(const std::string& peer, const std::string& what);

// True if `object` is nil, does not exist any more, or cannot be reached (any system exception).
bool is_gone(CORBA::Object_ptr object);

// What one _non_existent() call tells of an object. kGone: nil, no such object, or nobody at its
// address (TRANSIENT, COMM_FAILURE); kNoAnswer: it did not answer in time (TIMEOUT, or
// TRANSIENT_CallTimedout when the call had to open a connection: it may be busy or paused, which
// is not death); kAlive: it answered that it exists.
enum class Liveness { kAlive, kGone, kNoAnswer };
Liveness liveness(CORBA::Object_ptr object);

// The text of a CORBA exception: "TRANSIENT (TRANSIENT_ConnectFailed)", "BAD_PARAM", or the
// repository ID of a user exception.
std::string describe(const CORBA::Exception& e);

}  // namespace urs::rtc
