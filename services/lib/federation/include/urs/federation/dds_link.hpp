#pragma once
// DdsLink: what one space's bridge shares with the other spaces over DDS (Fast DDS), per
// idl/dds/Federation.idl: it announces the services its space offers on the catalog topic, learns
// the other spaces' entries (and loses them when their bridge stops asserting its liveliness),
// serves calls to its space's services and makes calls to the others' (DDS-RPC: a request topic
// per space, a reply topic per calling space, replies correlated by request id).
//
// Calls travel as the neutral call model (urs/call/call.hpp): CallReply.status is a call::Status
// number, and the calls served arrive as a call::Request and a call::Responder.
//
// Threads: handlers run on DDS listener threads and must not block; call() and oneway() block (a
// first match, then the reply): never from a DDS listener or Planet I/O thread (see
// src/dds_calls.cpp). call_async() and oneway_async() never block: a forwarded call starts on the
// thread that received it and its reply is handed on from the thread that read it.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "urs/call/call.hpp"
#include "urs/federation/dds_security.hpp"

namespace eprosima::fastdds::dds {
class DataWriter;
class DomainParticipant;
struct SampleInfo;
}  // namespace eprosima::fastdds::dds

namespace urs::federation {

// The roles the link gives the callers of other spaces (call::Identity.role).
inline constexpr const char* kVerifiedSpaceRole = "member";  // its space proven by its certificate
inline constexpr const char* kDeclaredSpaceRole = "bridge";  // its space only as its request declared it

// What is wrong with the name a request gives its caller inside its space (CallRequest.caller_name,
// non-empty), one sentence; "" if nothing. A name is 1 to kMaxCallerName printable ASCII
// characters but white space, not beginning "dds:" (the names of the bridges themselves). It may
// hold '/' (a CAMUS task's "task:square-path/r3"): a SPACE/NAME pattern's NAME is all after its
// first '/', so "kr/task:*" names it.
inline constexpr std::size_t kMaxCallerName = 128;
std::string caller_name_problem(const std::string& name);

struct DdsOptions {
  uint32_t domain = 0;
  std::string space;   // this space
  std::string bridge;  // this bridge's name
  // How long a silent bridge (dead, cut off) keeps its entries in the others' catalogs: its
  // writers' liveliness lease (asserted four times a lease).
  std::chrono::milliseconds lease{3000};
  // How long a silent participant stays discovered at the others (announced four times a
  // `lease`), at least `lease`. Longer than `lease` on purpose: a peer that drops this participant
  // while this one keeps the peer (its own lease being longer) is never sent this participant's
  // endpoints again by Fast DDS 2.9, so it must be no shorter than other vendors' leases
  // (Cyclone DDS: 10 s) for a pause or cut shorter than theirs to leave no one behind.
  std::chrono::milliseconds participant_lease{10000};
  bool udp_only = false;                    // no shared memory (required between containers)
  uint32_t socket_buffer_bytes = 4u << 20;  // socket send/receive buffers (UDP or TCP), for large samples
  uint32_t shm_segment_bytes = 8u << 20;    // shared-memory segment, when used
  // The IPv4 addresses of this host's interfaces the link's UDP or TCP transport may use: it
  // listens, sends and announces locators on these only (Fast DDS's interfaceWhiteList), e.g.
  // {"127.0.0.1"} for a link that stays on this host. Empty: every interface. Fast DDS 2.9 sends
  // to no unicast address outside the list (peers must announce one of them), and drops an
  // address no interface has (with every one dropped it uses none that works): the bridge's
  // configuration refuses such an entry. Shared memory (same host, no interface) is unaffected.
  std::vector<std::string> interfaces;
  // Unicast addresses of other bridges' hosts ("HOST" or "HOST:PORT"), for networks without
  // multicast; without a port, the default ports of the first participants of the domain.
  std::vector<std::string> initial_peers;
  // A Fast DDS discovery server instead of multicast discovery (sites that pass no multicast):
  // `discovery_listen` "HOST:PORT" makes this participant the server with id `discovery_server_id`;
  // `discovery_servers` "HOST:PORT" makes it a client of those servers (the N-th has id N, as in
  // ROS_DISCOVERY_SERVER).
  std::string discovery_listen;
  uint32_t discovery_server_id = 0;
  std::vector<std::string> discovery_servers;
  // DDS-Security (authentication, access control, encryption) when `security.enabled()`: only
  // members of the federation join, each within its permissions.
  DdsSecurity security;
  // The transport of the link: UDP (with shared memory unless udp_only), or TCP only, for sites
  // behind NAT and firewalls (docs/sites.md). Over TCP one site listens on one port and the
  // others connect out to it; discovery, catalog, state and calls all pass through those
  // connections (a listening site answers a connecting one over the connection it opened).
  enum class Transport { kUdp, kTcp };
  Transport transport = Transport::kUdp;
  struct Tcp {
    // This site listens on this TCP port (0: it only connects out).
    uint16_t listen = 0;
    // The IPv4 address and port the other sites reach this one at (the router's public address
    // and the port it forwards to `listen`): announced with this participant's locators. Without
    // it, a listening site announces its private address, and the others discover it but match
    // none of its endpoints. On a site that only connects out, an address without port, announced
    // as its WAN address: needed where the listener's network has this site's private address
    // too (else the listener takes this site for itself), harmful on the listener's own host
    // (the two never link): empty by default.
    std::string public_address;
    uint16_t public_port = 0;  // 0: `listen`
    // The listening sites to connect to, "HOST:PORT" (their public address and port).
    std::vector<std::string> connect;
  };
  Tcp tcp;
};

// The logical port (Fast DDS's TCP transport multiplexes "logical ports" over one connection) of
// a discovery server's metatraffic over TCP: the server and its clients must name the same one.
// 7400 is never one Fast DDS gives a participant (those are 7410 and up).
inline constexpr uint16_t kTcpDiscoveryServerLogicalPort = 7400;

struct ServiceEntry {
  std::string space;
  std::string name;
  std::string interface_name;
  std::string repository_id;
  std::string origin;
  std::string bridge;
  uint32_t deadline_ms = 0;
  std::string descriptor_set;
};

// What this bridge's calls to one other space met (DdsLink::space_calls()): the round trip of each
// reply read (its request written to its reply read, the serving there included), and the failures
// the link itself gave a call: no reply within its deadline, the space's bridges gone or lost
// during the call or before it, the request not written. An error the called space answered is
// that call's outcome, not the link's, and is not counted here.
struct SpaceCalls {
  uint64_t replies = 0;                                     // replies read
  uint64_t request_bytes = 0;                               // payload bytes of the requests written (oneway too)
  uint64_t reply_bytes = 0;                                 // payload bytes of the replies read
  double round_trip_seconds = 0;                            // their round trips, summed
  double last_round_trip_seconds = 0;                       // the latest one's
  std::map<call::Status, uint64_t> failures;                // by the status the link gave
  std::chrono::system_clock::time_point last_failure_at{};  // the epoch if none
};

// What this bridge served to one other space's calls (DdsLink::space_served()), by the caller's
// space as the link took it (proven on a secured link, declared on a plain one).
struct SpaceServed {
  uint64_t request_bytes = 0;  // payload bytes of the requests read (oneway too)
  uint64_t reply_bytes = 0;    // payload bytes of the replies written
};

class DdsLink {
 public:
  // Spaces beyond this many get no SpaceCalls of their own (their calls are made, not counted).
  static constexpr std::size_t kMaxCountedSpaces = 64;

  // The other spaces' catalog changed (an entry written, disposed, or its bridge lost or back):
  // read catalog() for what it holds now. Runs on a DDS thread; must not block.
  using CatalogHandler = std::function<void()>;
  // A call to this space's services. Runs on a DDS listener thread. The request's deadline counts
  // from its arrival; its caller is Identity{space, name, role}: on a secured link the space the
  // writer's participant proved with its certificate (role "member", dds_identity.hpp), whatever
  // the request declares; otherwise the space the request declares (role "bridge"). The name is
  // the request's caller_name (who calls inside that space, which the space speaks for), or
  // "dds:<space>" when it names none. The reply goes to that space. The responder answers from any thread, once; a
  // oneway call's answers nowhere. Answered on this link's listener thread (inside the handler, or by dropping the
  // responder there), the reply is written by the link's replier thread instead: writing it there may create the reply
  // writer, which can deadlock Fast DDS 2.9's in-process delivery. Replies after the link is destroyed are dropped.
  using CallHandler = std::function<void(call::Request request, call::Responder responder)>;

  // Joins the domain; throws std::runtime_error if DDS refuses (bad domain, bad peer address).
  DdsLink(DdsOptions options, CatalogHandler on_catalog, CallHandler on_call);
  ~DdsLink();  // leaves the domain: the others drop this space's entries at once
  DdsLink(const DdsLink&) = delete;
  DdsLink& operator=(const DdsLink&) = delete;

  const DdsOptions& options() const { return options_; }
  // The link's participant, for the other endpoints a space shares on it (StateLink).
  eprosima::fastdds::dds::DomainParticipant* participant() const;
  // Asserts the liveliness of `writer`, a keyed-state writer of that participant (manual-by-topic
  // liveliness with the link's lease), with the link's own, until let_go(writer); after let_go()
  // returns, the writer may be deleted. Not from a DDS listener.
  void keep_alive(eprosima::fastdds::dds::DataWriter* writer);
  void let_go(eprosima::fastdds::dds::DataWriter* writer);
  // Whether a sample of the link naming `space` (a shared state sample of StateLink), read with
  // `info`, is taken as that space's: each space speaks only for itself. On a secured link only if
  // its writer's participant proved `space` with its certificate; on a plain link always (nothing
  // proves a writer's space there). A refusal is logged once per writer and space, as "<kind>
  // <space>/<name>" (dds_identity.hpp). The catalog applies the same rule to its entries.
  bool speaks_for(const eprosima::fastdds::dds::SampleInfo& info, const std::string& space, const char* kind,
                  const std::string& name) const;

  // What the other spaces offer now: every live entry of the catalog (read from the reader's
  // cache, whose instances DDS keeps up to date), but those of bridges whose liveliness is lost
  // and, on a secured link, those written by a participant that did not prove the entry's space.
  std::vector<ServiceEntry> catalog() const;

  // Since when `space` has been lost: every bridge of it that this link saw lost its liveliness or
  // left (killed, paused, cut off, stopped), and none is back yet; nullopt if it was never lost or
  // is back. A space never seen is not lost: it is unknown.
  std::optional<std::chrono::steady_clock::time_point> lost_since(const std::string& space) const;
  // Since when `space` has been reached: an entry of it read from a bridge alive, and not every
  // bridge of it lost since; nullopt if it is not reached now (lost, or never seen).
  std::optional<std::chrono::system_clock::time_point> reached_since(const std::string& space) const;

  // How many times the catalog reader matched a catalog writer of another participant (every
  // bridge and gateway has one; one matched again counts again) since the link was joined. 0: it
  // has met no one it can exchange with, e.g. a site connecting over TCP whose connection carries
  // nothing, or carried discovery only (its endpoints never matched).
  uint64_t catalog_writers_matched() const;

  // The calls made to each other space (at most kMaxCountedSpaces), by space.
  std::map<std::string, SpaceCalls> space_calls() const;
  // The calls served to each other space (at most kMaxCountedSpaces), by space.
  std::map<std::string, SpaceServed> space_served() const;
  // Samples the link's readers lost (DDS's SAMPLE_LOST: a gap in a writer's sequence, a sample
  // dropped for a full history or a best-effort one not received), by topic, since the link was
  // joined. DDS does not say whose sample was lost, so they are not counted per space.
  std::map<std::string, uint64_t> samples_lost() const;
  // Counts a failure given to a call to `space` for the link's reasons by the link's user (a call
  // refused because the space is held unreachable), as the link counts its own.
  void count_failure(const std::string& space, const call::Reply& reply);
  // Counts `count` more samples lost by a reader of `topic` on this link's participant (its own
  // readers' and StateLink's listeners). Any thread.
  void count_samples_lost(const std::string& topic, uint64_t count);

  // This space's catalog: announce (or update) and withdraw one service.
  void announce(const ServiceEntry& entry);
  void withdraw(const std::string& name);

  // Calls a service of another space. UNAVAILABLE at once if no bridge of that space is matched
  // (unknown, dead or unreachable space) or every one of them lost its liveliness; PROVIDER_GONE
  // if it leaves or loses it during the call;
  // DEADLINE_EXCEEDED when the deadline passes; otherwise the remote outcome. `caller` names who
  // calls inside this space (CallRequest.caller_name: the name this space's CAMUS server
  // authenticated); empty: this bridge itself. On a secured link a reply is taken only from a
  // participant that proved `space` (another member's is ignored, logged once).
  call::Reply call(const std::string& space, const std::string& service, const std::string& operation,
                   std::string payload, std::chrono::milliseconds deadline, const std::string& caller = {});
  bool oneway(const std::string& space, const std::string& service, const std::string& operation, std::string payload,
              const std::string& caller = {});

  // call() without blocking: `done` gets the same outcome, once, never under the link's locks: on
  // a DDS listener thread (the reply; PROVIDER_GONE), the link's call thread (DEADLINE_EXCEEDED),
  // the link's destructor (UNAVAILABLE "bridge stopping"), or this thread before it returns (the
  // call refused at once). False, with nothing sent, `payload` untouched and `done` dropped
  // uncalled, when the call would have to wait: no request writer to `space` is matched yet (its
  // first call, which call() makes and waits for).
  bool call_async(const std::string& space, const std::string& service, const std::string& operation,
                  std::string&& payload, std::chrono::milliseconds deadline, const std::string& caller,
                  std::function<void(call::Reply)> done);
  // oneway() without blocking: whether it was sent; nullopt, with nothing sent and `payload`
  // untouched, when it would have to wait for a first match (oneway() does).
  std::optional<bool> oneway_async(const std::string& space, const std::string& service, const std::string& operation,
                                   std::string&& payload, const std::string& caller = {});

 private:
  struct Impl;
  const DdsOptions options_;
  std::shared_ptr<Impl> impl_;  // shared with the responders of the calls served (weakly)
};

}  // namespace urs::federation
