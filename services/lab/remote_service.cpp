#include "remote_service.hpp"

#include <stdexcept>

#include "urs/agent/agent.hpp"
#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/client.hpp"
#include "urs/rt_call/provider_port.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/schema.hpp"

namespace urs::lab {

namespace gp = google::protobuf;

void expect_ok(const planet::CallResult& result, const std::string& what) {
  if (result.ok()) return;
  throw std::runtime_error(what + ": " + std::string(planet::status_name(result.status)) +
                           (result.exception_type.empty() ? "" : " " + result.exception_type) + " " + result.message);
}

namespace {

class CamusService : public RemoteService {
 public:
  CamusService(planet::Client& client, std::string service) : client_(client), service_(std::move(service)) {}
  planet::CallResult call(const std::string& operation, const gp::Message& request, gp::Message& reply,
                          std::chrono::milliseconds deadline) override {
    auto result = client_.call(service_, operation, request.SerializeAsString(), deadline);
    if (result.ok() && !reply.ParseFromString(result.payload)) {
      return planet::CallResult::error(planet::INTERNAL, service_ + " replied with an invalid " + reply.GetTypeName());
    }
    return result;
  }
  std::string where() const override { return "CAMUS service " + service_; }

 private:
  planet::Client& client_;
  std::string service_;
};

class RtProvider : public RemoteService {
 public:
  RtProvider(rtc::Orb& orb, CORBA::Object_ptr target, const gp::ServiceDescriptor& interface, std::string where)
      : proxy_(orb.orb(), target, interface), where_(std::move(where)) {}
  planet::CallResult call(const std::string& operation, const gp::Message& request, gp::Message& reply,
                          std::chrono::milliseconds deadline) override {
    const gp::MethodDescriptor* method = proxy_.interface().FindMethodByName(operation);
    if (method == nullptr) return planet::CallResult::error(planet::UNKNOWN_OPERATION, operation);
    agent::CallContext context;
    context.deadline = std::chrono::steady_clock::now() + deadline;
    context.events = &events_;
    const agent::Outcome outcome = proxy_.invoke(*method, request, reply, context);
    planet::CallResult result;
    result.status = planet::to_planet(outcome.status);
    result.message = outcome.message;
    if (outcome.exception) {
      result.exception_type = outcome.exception->GetTypeName();
      result.payload = outcome.exception->SerializeAsString();
    }
    return result;
  }
  std::string where() const override { return "RT provider " + where_; }

 private:
  corba_agent::CorbaProxyAgent proxy_;
  agent::DiscardingEventSink events_;
  std::string where_;
};

}  // namespace

std::unique_ptr<RemoteService> camus_service(planet::Client& client, const std::string& service) {
  return std::make_unique<CamusService>(client, service);
}

std::unique_ptr<RemoteService> rt_provider(rtc::Orb& orb, rtc::NamingClient& naming, const std::string& port_address,
                                           const gp::ServiceDescriptor& interface) {
  const auto colon = port_address.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("'" + port_address + "' is not PATH:PORT");
  CORBA::Object_var object = naming.resolve(port_address.substr(0, colon));
  RTC::RTObject_var component = RTC::RTObject::_narrow(object);
  RTC::PortService_var port = rtc::find_port(component, port_address.substr(colon + 1));
  if (CORBA::is_nil(port)) throw std::runtime_error(port_address + ": no such port");
  const std::string wanted = schema::repository_id(interface);
  for (const auto& provided : rt_call::offered_by(port)) {
    CORBA::Object_var target = orb.string_to_object(provided.ior);
    if (target->_is_a(wanted.c_str())) return std::make_unique<RtProvider>(orb, target, interface, port_address);
  }
  throw std::runtime_error(port_address + " provides no " + wanted);
}

}  // namespace urs::lab
