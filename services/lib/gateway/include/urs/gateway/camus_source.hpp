#pragma once
// CamusSource: a CAMUS space seen through its server, over Planet (docs/dashboard.md):
//   services    every registered service (with origin and bridge, from its properties)
//   components  the service agents (the SAMs' services, a bridge's proxies), state Available
//   operations  every operation of every service but camus.registry's, called with the caller's
//               own Planet session (its login), never with the gateway's
//   context     every entry, then each change (events "context/<key>")
//   events      every event of the space ("#"), payloads decoded with the registry's descriptions
// The gateway's own session (--token-file) only reads. The registry is read again when a
// "registry/<name>" event says it changed, after every reconnect, and every `refresh`.
//
// Threads: one of its own (registry and context reads, which block); events are reported on the
// Planet client's I/O thread; calls are asynchronous (their replies come on the caller's session's
// I/O thread).

#include <atomic>
#include <memory>
#include <set>
#include <string>

#include "urs/gateway/logins.hpp"
#include "urs/gateway/payloads.hpp"
#include "urs/gateway/poller.hpp"
#include "urs/gateway/space_view.hpp"
#include "urs/planet/client.hpp"

namespace urs::gateway {

struct CamusSourceOptions {
  std::string space;
  planet::ClientOptions client;  // the gateway's own session: host, port, token, peer name
  std::chrono::milliseconds refresh{5000};
  std::chrono::milliseconds read_timeout{5000};  // of its registry and context reads
};

class CamusSource : public SpaceSource {
 public:
  // `logins` outlives this (the callers' sessions come from it).
  CamusSource(CamusSourceOptions options, Logins& logins);
  ~CamusSource() override;

  void start(ViewSink& sink) override;
  void stop() override;

 private:
  void refresh();
  void read_context();
  void on_event(const planet::Event& event);
  void call(const Caller& caller, const std::string& service, const google::protobuf::MethodDescriptor& method,
            std::string json, std::function<void(CallReply)> reply);

  const CamusSourceOptions options_;
  Logins& logins_;
  PayloadDecoder decoder_;
  std::unique_ptr<planet::Client> client_;
  ViewSink* sink_ = nullptr;
  std::set<std::string> described_;      // interfaces in decoder_.pool() (the poller's own)
  std::atomic<bool> context_due_{true};  // after every (re)connection
  Poller poller_;
};

}  // namespace urs::gateway
