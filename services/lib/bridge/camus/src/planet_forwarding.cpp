#include "urs/bridge/camus/planet_forwarding.hpp"

#include "camus.pb.h"
#include "urs/planet/call_adapter.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;

namespace {

constexpr auto kCamusTimeout = std::chrono::milliseconds(2000);  // a registry call

// The calls of a forwarding agent to a service of this space's CAMUS server. The client calls as
// itself (the bridge): Planet carries no caller on behalf of another.
class PlanetCallSink : public core::CallSink {
 public:
  explicit PlanetCallSink(std::weak_ptr<planet::Client> client) : client_(std::move(client)) {}

  bool start(call::Request& request, Done done) override {
    const auto client = client_.lock();
    if (!client) {
      done(closed());
      return true;
    }
    if (request.oneway) {
      done(client->oneway(request.service, request.operation, std::move(request.payload)) ? call::Reply::success({})
                                                                                          : queue_full());
      return true;
    }
    // The client never blocks to send: the reply comes on its I/O thread.
    client->call_async(
        request.service, request.operation, std::move(request.payload), planet::deadline_left(request),
        [done = std::move(done)](planet::CallResult result) { done(planet::to_reply(std::move(result))); });
    return true;
  }

  call::Reply call(call::Request request) override {
    const auto client = client_.lock();
    if (!client) return closed();
    if (request.oneway) {
      return client->oneway(request.service, request.operation, std::move(request.payload)) ? call::Reply::success({})
                                                                                            : queue_full();
    }
    return planet::to_reply(
        client->call(request.service, request.operation, std::move(request.payload), planet::deadline_left(request)));
  }

  std::string to() const override { return "the CAMUS server"; }

 private:
  static call::Reply closed() {
    return call::Reply::error(call::Status::UNAVAILABLE, "the bridge's CAMUS session is closed");
  }
  static call::Reply queue_full() {
    return call::Reply::error(call::Status::UNAVAILABLE, "the bridge's queue towards the CAMUS server is full");
  }
  const std::weak_ptr<planet::Client> client_;
};

}  // namespace

const gp::ServiceDescriptor& describe_service(planet::Client& client, const std::string& service,
                                              schema::SchemaPool& pool) {
  camus::DescribeRequest request;
  request.set_service(service);
  const auto result = client.call("camus.registry", "Describe", request.SerializeAsString(), kCamusTimeout);
  if (!result.ok()) {
    const std::string why =
        "describing '" + service + "': " + std::string(planet::status_name(result.status)) + " " + result.message;
    if (result.status == planet::UNKNOWN_SERVICE || result.status == planet::NOT_FOUND) throw util::NotFound(why);
    throw util::Unavailable(why);
  }
  camus::DescribeReply reply;
  if (!reply.ParseFromString(result.payload)) {
    throw util::ProtocolError("describing '" + service + "': camus.registry.Describe returned an unreadable reply");
  }
  const std::string error = pool.add_descriptor_set(reply.descriptor_set());
  if (!error.empty()) throw util::ProtocolError("interface of '" + service + "' cannot be loaded: " + error);
  const gp::ServiceDescriptor* interface = pool.find_service(reply.interface());
  if (interface == nullptr) {
    throw util::ProtocolError("the description of '" + service + "' does not define " + reply.interface());
  }
  return *interface;
}

std::shared_ptr<core::ForwardingAgent> planet_forwarder(std::weak_ptr<planet::Client> client, std::string service,
                                                        const gp::ServiceDescriptor& interface) {
  return std::make_shared<core::ForwardingAgent>(std::make_shared<PlanetCallSink>(std::move(client)),
                                                 std::move(service), interface);
}

}  // namespace urs::bridge
