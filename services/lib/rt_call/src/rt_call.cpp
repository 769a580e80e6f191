#include "urs/rt_call/rt_call.hpp"

#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/rt_call/provider_port.hpp"
#include "urs/schema/json.hpp"

namespace urs::rt_call {

ProviderTarget provider_target(RTC::PortService_ptr port, const schema::InterfaceCatalog& catalog,
                               const std::string& type_name, const std::string& what) {
  ProviderTarget target;
  std::vector<rt_call::ProvidedInterface> offered;
  for (auto& provided : rt_call::offered_by(port)) {
    if (type_name.empty() || provided.type_name == type_name) offered.push_back(std::move(provided));
  }
  if (offered.size() != 1) {
    target.error = what + (offered.empty() ? ": provides no interface" : ": provides several interfaces") +
                   (type_name.empty() ? "" : " of type " + type_name) +
                   (offered.size() > 1 ? " (choose one with --interface)" : "");
    return target;
  }
  target.ior = offered.front().ior;
  target.type_name = offered.front().type_name;
  target.interface = catalog.find_interface(rt_call::ior_type_id(target.ior), target.type_name);
  if (target.interface == nullptr) {
    target.error = what + " provides " + target.type_name + ", whose IDL is not known here (give it with --idl FILE)";
  }
  return target;
}

ProviderOutcome call_provider(const rtc::Orb& orb, const ProviderTarget& target,
                              const google::protobuf::MethodDescriptor& method,
                              const google::protobuf::Message& request, google::protobuf::Message& reply,
                              std::chrono::milliseconds deadline, const std::string& what) {
  try {
    CORBA::Object_var object = orb.string_to_object(target.ior);
    corba_agent::CorbaProxyAgent consumer(
        orb.orb(), object, *target.interface,
        corba_agent::CorbaProxyOptions{deadline, deadline, {}, orb.max_calls_per_peer()});
    class NoEvents : public agent::EventSink {
     public:
      call::Reply publish(const std::string&, const google::protobuf::Message&) override { return {}; }
    } events;
    agent::CallContext context;
    context.service = what;
    context.deadline = std::chrono::steady_clock::now() + deadline;
    context.events = &events;
    const agent::Outcome outcome = consumer.invoke(method, request, reply, context);
    ProviderOutcome out{outcome.status, outcome.message, {}, {}};
    if (outcome.exception) {
      out.exception_type = outcome.exception->GetDescriptor()->full_name();
      schema::message_to_json(*outcome.exception, out.exception_json);
    }
    return out;
  } catch (const std::invalid_argument& e) {
    return {call::Status::BAD_ARGUMENTS, what + ": " + e.what(), {}, {}};
  } catch (const CORBA::Exception& e) {
    return {call::Status::UNAVAILABLE, what + ": " + rtc::describe(e), {}, {}};
  }
}

}  // namespace urs::rt_call
