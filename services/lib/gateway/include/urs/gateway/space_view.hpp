#pragma once
// The gateway's two narrow interfaces towards the spaces (docs/dashboard.md, "Inside"):
//
//   ViewSink   what a source of the picture reports (services, components, poses, context, events),
//              each as the neutral messages of gateway.proto; the WebSocket side only ever reads
//              what arrives here.
//   Operation  one thing a client may do (call an operation of a service, change a component's
//              lifecycle state): a name, a request and reply type, and a handler that acts with
//              the caller's own credential.
//
// A source (SpaceSource) is one way into a space: the CAMUS server, the naming service, the DDS
// link, the devices' DDS domain. Sources know nothing of WebSockets; the gateway knows sources
// only through these interfaces, so a future adapter (the bridge's neutral call) plugs in here.

#include <google/protobuf/descriptor.h>

#include <string>
#include <vector>

#include "gateway.pb.h"
#include "urs/gateway/hub.hpp"

namespace urs::gateway {

// One operation clients may call, offered as a Foxglove service named `name`.
struct Operation {
  std::string name;     // e.g. "diag/echo", "labpc.host_cxt/Robot0.rtc:navigation/moveTo"
  std::string type;     // e.g. "URS.Diagnostic.echo", "urs.gateway.Lifecycle.activate"
  std::string space;    // the space of the service it calls
  std::string service;  // that service's name (Service.name), or the component's (Component.name)
  const google::protobuf::Descriptor* request = nullptr;  // valid as long as the source
  const google::protobuf::Descriptor* response = nullptr;
  ServiceHandler handler;  // runs the call; must not block the calling thread (hand work to a pool)
};

// Where sources report. Every method may be called from any thread and returns quickly; each
// list replaces what the same `source` reported before.
class ViewSink {
 public:
  virtual ~ViewSink() = default;
  virtual void services(const std::string& source, std::vector<Service> now) = 0;
  virtual void components(const std::string& source, std::vector<Component> now) = 0;
  virtual void operations(const std::string& source, std::vector<Operation> now) = 0;
  virtual void pose(const Pose& pose) = 0;
  virtual void context(const ContextEntry& entry) = 0;  // entry.removed: the key ended
  virtual void event(const Event& event) = 0;
};

// One way into a space. start() begins reporting to the sink (threads of its own, returns at
// once); stop() stops and joins them; after stop() nothing reaches the sink and no handler of
// its operations runs any more.
class SpaceSource {
 public:
  virtual ~SpaceSource() = default;
  virtual void start(ViewSink& sink) = 0;
  virtual void stop() = 0;
};

}  // namespace urs::gateway
