#pragma once
// RtSource: an RT-Middleware space seen through its naming service (docs/dashboard.md), the way
// RTSystemEditor sees it, with the standard RTC interfaces only (OpenRTM-aist's components too):
//   components  every RT-Component bound in the naming service: state, type, ports (kind, data
//               type, provided and required interfaces) and their connections
//   services    every provider port (an interface it provides) — the RT providers, and the RTCs a
//               bridge made for other spaces' services and CAMUS services
//   operations  each provider port's operations, called through DII (rt_call.hpp) with the
//               interface's description; and activate / deactivate / reset of every component
//               owning an execution context
// The naming service is read every `poll`.
//
// Threads: one poll thread; calls run on a worker pool of their own (CORBA calls block).
// The RT side has no per-person credential today: the hub lets only operators call.

#include <memory>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/gateway/poller.hpp"
#include "urs/gateway/space_view.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::gateway {

struct RtSourceOptions {
  std::string space;
  std::string naming;  // HOST:PORT of the naming service
  std::chrono::milliseconds poll{1000};
  std::chrono::milliseconds call_deadline{10000};  // bound on an operation called through the gateway
  unsigned workers = 4;                            // calls at once
  std::vector<std::string> idl;                    // interfaces not built in (IDL files)
  std::vector<std::string> include_dirs;
};

class RtSource : public SpaceSource {
 public:
  // `orb` outlives this. Throws std::runtime_error if an IDL file cannot be loaded.
  RtSource(RtSourceOptions options, rtc::Orb& orb);
  ~RtSource() override;

  void start(ViewSink& sink) override;
  void stop() override;

 private:
  void poll();
  void call(const std::string& path, const std::string& port, const std::string& type_name,
            const google::protobuf::MethodDescriptor& method, std::string json, std::function<void(CallReply)> reply);
  void lifecycle(const std::string& path, const std::string& transition, std::function<void(CallReply)> reply);

  const RtSourceOptions options_;
  rtc::Orb& orb_;
  rtc::NamingClient naming_;
  schema::InterfaceCatalog catalog_;
  ViewSink* sink_ = nullptr;
  std::unique_ptr<agent::WorkerPool> pool_;
  bool reported_unreachable_ = false;  // the poller's own
  Poller poller_;
};

}  // namespace urs::gateway
