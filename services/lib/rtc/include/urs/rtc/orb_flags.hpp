#pragma once
// The flags of a program hosting RT-Components (urs-rtc-manager, urs-bridge): the naming context
// they are bound under and how the ORB listens and calls. Header-only (CLI11 is header-only too;
// the App type is a template parameter so that this library does not depend on it).

#include <chrono>
#include <string>

#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"

namespace urs::rtc {

struct OrbFlags {
  std::string host;             // --host/--host-context: context <host>.host_cxt ("": this machine's name)
  std::string listen;           // --listen HOST:PORT of the object references ("": see orb_options_from)
  int call_timeout_ms = 10000;  // --call-timeout-ms
  unsigned max_calls_per_peer = kDefaultMaxCallsPerPeer;  // --max-calls-per-peer
};

// Adds --host/--host-context (env URS_HOST_CONTEXT), --listen (help naming `whose` object
// references), --call-timeout-ms (help `timeout_help`) and --max-calls-per-peer to `app`.
template <typename App>
void add_orb_flags(App& app, OrbFlags& flags, const std::string& whose, const std::string& timeout_help) {
  app.add_option("--host,--host-context", flags.host,
                 "Naming context <host>.host_cxt (env URS_HOST_CONTEXT; default: this machine's host name)")
      ->envname("URS_HOST_CONTEXT");
  app.add_option("--listen", flags.listen,
                 "HOST:PORT for " + whose + " object references (default: an ephemeral port on this host's " +
                     "address towards the naming service)");
  app.add_option("--call-timeout-ms", flags.call_timeout_ms, timeout_help)->capture_default_str();
  app.add_option("--max-calls-per-peer", flags.max_calls_per_peer,
                 "Calls in flight at once to one process (an RT provider's); a call beyond waits, within its deadline, "
                 "for one of them to return (1.." +
                     std::to_string(kMaxCallsPerPeerLimit) + ")")
      ->capture_default_str();
}

// The ORB's options from the flags: listening on --listen, else on this host's address towards
// `naming` (HOST:PORT of the naming service; "" leaves the choice to omniORB). Throws
// urs::util::ConfigError naming the flag (--listen, --naming, --call-timeout-ms,
// --max-calls-per-peer) and the reason.
inline OrbOptions orb_options_from(const OrbFlags& flags, const std::string& naming) {
  OrbOptions options;
  if (!flags.listen.empty()) {
    options.endpoint = endpoint_from_address(flags.listen, "--listen");
  } else if (!naming.empty()) {
    options.endpoint = endpoint_towards(naming, "--naming");
  }
  if (flags.call_timeout_ms < 0) throw util::ConfigError("--call-timeout-ms: must be >= 0");
  options.call_timeout = std::chrono::milliseconds(flags.call_timeout_ms);
  if (flags.max_calls_per_peer == 0 || flags.max_calls_per_peer > kMaxCallsPerPeerLimit) {
    throw util::ConfigError("--max-calls-per-peer: " + std::to_string(flags.max_calls_per_peer) + " is outside 1.." +
                            std::to_string(kMaxCallsPerPeerLimit));
  }
  options.max_calls_per_peer = flags.max_calls_per_peer;
  return options;
}

}  // namespace urs::rtc
