#include "urs/gateway/rt_source.hpp"

#include <google/protobuf/dynamic_message.h>
#include <spdlog/spdlog.h>

#include <map>
#include <set>

#include "urs/rt_call/rt_call.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/json.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;

namespace {

constexpr const char* kSource = "naming";

// "<instance>.<port>" without the instance, as ports are named within their component.
std::string short_port_name(const std::string& name) {
  const auto dot = name.find('.');
  return dot == std::string::npos ? name : name.substr(dot + 1);
}

std::string text(const SDOPackage::NVList& list, const std::string& name) {
  return rtc::nv_string(list, name).value_or("");
}

}  // namespace

RtSource::RtSource(RtSourceOptions options, rtc::Orb& orb)
    : options_(std::move(options)), orb_(orb), naming_(orb, options_.naming) {
  for (const auto& idl : options_.idl) {
    for (const auto& loaded : catalog_.load_idl(idl, options_.include_dirs)) {
      spdlog::info("gateway: interface {} loaded from {}", loaded, idl);
    }
  }
}

RtSource::~RtSource() { stop(); }

void RtSource::start(ViewSink& sink) {
  sink_ = &sink;
  pool_ = std::make_unique<agent::WorkerPool>(options_.workers);
  poller_.start(options_.poll, [this] { poll(); });
}

void RtSource::stop() {
  poller_.stop();
  if (pool_) pool_->stop();  // queued calls are answered "cancelled"
}

void RtSource::poll() {
  std::vector<rtc::NamingClient::Entry> entries;
  try {
    entries = naming_.list_objects("");
    if (reported_unreachable_) spdlog::info("gateway: the naming service of {} answers again", options_.space);
    reported_unreachable_ = false;
  } catch (const std::exception& e) {
    if (!reported_unreachable_) spdlog::warn("gateway: the naming service of {}: {}", options_.space, e.what());
    reported_unreachable_ = true;
    sink_->services(kSource, {});
    sink_->components(kSource, {});
    sink_->operations(kSource, {});
    return;
  }
  std::vector<Service> services;
  std::vector<Component> components;
  std::vector<Operation> operations;
  std::map<std::string, std::vector<std::string>> connectors;  // connector id -> "<path>:<port>"
  for (const auto& entry : entries) {
    if (entry.kind != "rtc") continue;
    Component component;
    component.set_space(options_.space);
    component.set_name(entry.path);
    component.set_kind("rtc");
    const auto slash = entry.path.find('/');
    component.set_host(slash == std::string::npos ? "" : entry.path.substr(0, slash));
    try {
      CORBA::Object_var object = naming_.resolve(entry.path);
      RTC::RTObject_var rtc = RTC::RTObject::_narrow(object);
      if (CORBA::is_nil(rtc)) continue;  // bound, but not an RT-Component
      RTC::ComponentProfile_var profile = rtc->get_component_profile();
      RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
      const bool owns_context = contexts->length() > 0 && !CORBA::is_nil(contexts[0]);
      component.set_state(owns_context ? rtc::state_name(contexts[0]->get_component_state(rtc)) : "Created");
      component.set_type_name(profile->type_name.in());
      component.set_origin(text(profile->properties, "urslink.origin"));
      component.set_lifecycle(owns_context);
      const std::string bridge = text(profile->properties, "urslink.bridge");
      for (CORBA::ULong i = 0; i < profile->port_profiles.length(); ++i) {
        const RTC::PortProfile& port_profile = profile->port_profiles[i];
        Port* port = component.add_ports();
        port->set_name(short_port_name(port_profile.name.in()));
        port->set_kind(text(port_profile.properties, "port.port_type"));
        port->set_data_type(text(port_profile.properties, "dataport.data_type"));
        const std::string address = entry.path + ":" + port->name();
        for (CORBA::ULong j = 0; j < port_profile.connector_profiles.length(); ++j) {
          const RTC::ConnectorProfile& connector = port_profile.connector_profiles[j];
          PortConnection* connection = port->add_connections();
          connection->set_id(connector.connector_id.in());
          connection->set_name(connector.name.in());
          connectors[connection->id()].push_back(address);
        }
        for (CORBA::ULong j = 0; j < port_profile.interfaces.length(); ++j) {
          const RTC::PortInterfaceProfile& provided = port_profile.interfaces[j];
          PortInterface* interface = port->add_interfaces();
          interface->set_type_name(provided.type_name.in());
          interface->set_instance_name(provided.instance_name.in());
          interface->set_polarity(provided.polarity == RTC::PROVIDED ? "provided" : "required");
          if (provided.polarity != RTC::PROVIDED) continue;
          const gp::ServiceDescriptor* described = catalog_.find_interface("", provided.type_name.in());
          Service service;
          service.set_space(options_.space);
          service.set_name(address);
          service.set_interface(described ? described->full_name() : std::string(provided.type_name.in()));
          service.set_origin(component.origin().empty() ? "rtc:" + address : component.origin());
          service.set_provider(entry.path);
          service.set_bridge(bridge);
          service.set_state(component.state());
          service.set_seen_via("naming");
          services.push_back(service);
          if (described == nullptr) continue;
          for (int m = 0; m < described->method_count(); ++m) {
            const gp::MethodDescriptor* method = described->method(m);
            Operation operation;
            operation.name = address + "/" + method->name();
            operation.type = method->full_name();
            operation.space = options_.space;
            operation.service = address;
            operation.request = method->input_type();
            operation.response = method->output_type();
            operation.handler = [this, path = entry.path, port_name = port->name(),
                                 type_name = std::string(provided.type_name.in()),
                                 method](const Caller&, std::string json, std::function<void(CallReply)> reply) {
              call(path, port_name, type_name, *method, std::move(json), std::move(reply));
            };
            operations.push_back(std::move(operation));
          }
        }
      }
    } catch (const CORBA::SystemException& e) {
      component.set_state("Unreachable");
      component.clear_ports();
      spdlog::debug("gateway: {} does not answer: {}", entry.path, rtc::describe(e));
    } catch (const std::exception& e) {
      component.set_state("Unreachable");
      component.clear_ports();
      spdlog::debug("gateway: {}: {}", entry.path, e.what());
    }
    if (component.lifecycle()) {
      for (const char* transition : {"activate", "deactivate", "reset"}) {
        Operation operation;
        operation.name = entry.path + "/" + transition;
        operation.type = std::string("urs.gateway.Lifecycle.") + transition;
        operation.space = options_.space;
        operation.service = entry.path;
        operation.request = LifecycleRequest::descriptor();
        operation.response = LifecycleReply::descriptor();
        operation.handler = [this, path = entry.path, transition = std::string(transition)](
                                const Caller&, std::string, std::function<void(CallReply)> reply) {
          lifecycle(path, transition, std::move(reply));
        };
        operations.push_back(std::move(operation));
      }
    }
    components.push_back(std::move(component));
  }
  // Each connection lists every port the gateway saw holding it (ports of other naming services
  // or of tools are not named).
  for (Component& component : components) {
    for (Port& port : *component.mutable_ports()) {
      for (PortConnection& connection : *port.mutable_connections()) {
        for (const auto& address : connectors[connection.id()]) connection.add_ports(address);
      }
    }
  }
  sink_->services(kSource, std::move(services));
  sink_->components(kSource, std::move(components));
  sink_->operations(kSource, std::move(operations));
}

void RtSource::call(const std::string& path, const std::string& port, const std::string& type_name,
                    const gp::MethodDescriptor& method, std::string json, std::function<void(CallReply)> reply) {
  pool_->post([this, path, port, type_name, &method, json = std::move(json), reply = std::move(reply)](bool cancelled) {
    if (cancelled) {
      reply(CallReply::failure("UNAVAILABLE: the gateway is stopping"));
      return;
    }
    const std::string what = path + ":" + port;
    gp::DynamicMessageFactory factory;
    std::unique_ptr<gp::Message> request(factory.GetPrototype(method.input_type())->New());
    std::unique_ptr<gp::Message> response(factory.GetPrototype(method.output_type())->New());
    const std::string error = schema::json_to_message(json.empty() ? "{}" : json, *request);
    if (!error.empty()) {
      reply(CallReply::failure("BAD_ARGUMENTS: " + error));
      return;
    }
    rt_call::ProviderOutcome outcome;
    try {
      CORBA::Object_var object = naming_.resolve(path);
      RTC::RTObject_var rtc = RTC::RTObject::_narrow(object);
      RTC::PortService_var service_port = CORBA::is_nil(rtc) ? RTC::PortService::_nil() : rtc::find_port(rtc, port);
      if (CORBA::is_nil(service_port)) {
        reply(CallReply::failure("UNKNOWN_SERVICE: " + what + " is not a port of an RT-Component any more"));
        return;
      }
      const rt_call::ProviderTarget target = rt_call::provider_target(service_port, catalog_, type_name, what);
      if (!target.error.empty()) {
        reply(CallReply::failure("UNKNOWN_SERVICE: " + target.error));
        return;
      }
      outcome = rt_call::call_provider(orb_, target, method, *request, *response, options_.call_deadline, what);
    } catch (const CORBA::SystemException& e) {
      reply(CallReply::failure("UNAVAILABLE: " + what + ": " + rtc::describe(e)));
      return;
    } catch (const std::exception& e) {
      reply(CallReply::failure("UNAVAILABLE: " + what + ": " + e.what()));
      return;
    }
    std::string out;
    if (outcome.status == call::Status::OK) {
      schema::message_to_json(*response, out);
      reply(CallReply::success(std::move(out)));
      return;
    }
    std::string why = std::string(call::status_name(outcome.status));
    if (!outcome.exception_type.empty()) why += " " + outcome.exception_type + " " + outcome.exception_json;
    if (!outcome.message.empty()) why += ": " + outcome.message;
    reply(CallReply::failure(std::move(why)));
  });
}

void RtSource::lifecycle(const std::string& path, const std::string& transition, std::function<void(CallReply)> reply) {
  pool_->post([this, path, transition, reply = std::move(reply)](bool cancelled) {
    if (cancelled) {
      reply(CallReply::failure("UNAVAILABLE: the gateway is stopping"));
      return;
    }
    try {
      CORBA::Object_var object = naming_.resolve(path);
      RTC::RTObject_var rtc = RTC::RTObject::_narrow(object);
      if (CORBA::is_nil(rtc)) {
        reply(CallReply::failure("UNKNOWN_SERVICE: " + path + " is not an RT-Component"));
        return;
      }
      RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
      if (contexts->length() == 0 || CORBA::is_nil(contexts[0])) {
        reply(CallReply::failure("PRECONDITION_NOT_MET: " + path + " owns no execution context"));
        return;
      }
      RTC::ExecutionContext_ptr context = contexts[0];
      const RTC::ReturnCode_t code = transition == "activate"     ? context->activate_component(rtc)
                                     : transition == "deactivate" ? context->deactivate_component(rtc)
                                                                  : context->reset_component(rtc);
      if (code != RTC::RTC_OK) {
        reply(CallReply::failure(std::string(rtc::return_code_name(code)) + ": " + transition + " " + path + " (now " +
                                 rtc::state_name(context->get_component_state(rtc)) + ")"));
        return;
      }
      LifecycleReply done;
      done.set_component(path);
      done.set_state(rtc::state_name(context->get_component_state(rtc)));
      std::string json;
      schema::message_to_json(done, json);
      reply(CallReply::success(std::move(json)));
      poller_.wake();  // the new state shows without waiting for the next poll
    } catch (const CORBA::SystemException& e) {
      reply(CallReply::failure("UNAVAILABLE: " + path + ": " + rtc::describe(e)));
    } catch (const std::exception& e) {
      reply(CallReply::failure("UNAVAILABLE: " + path + ": " + e.what()));
    }
  });
}

}  // namespace urs::gateway
