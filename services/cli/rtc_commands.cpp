#include "rtc_commands.hpp"

#include <algorithm>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "rtc_conf.hpp"
#include "rtc_session.hpp"
#include "urs/agent/agent.hpp"
#include "urs/rt_call/provider_port.hpp"
#include "urs/rt_call/rt_call.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/schema/interface_catalog.hpp"
#include "urs/schema/json.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/trace.hpp"

namespace urs::cli {
namespace {

using namespace rtc_cli;

std::string leaf_name(const rtc::NamingClient::Entry& entry) {
  return entry.kind.empty() ? entry.id : entry.id + "." + entry.kind;
}

std::string port_type(const RTC::PortProfile& port) {
  std::string type = rtc::nv_string(port.properties, "port.port_type").value_or("-");
  if (const auto data_type = rtc::nv_string(port.properties, "dataport.data_type")) type += " " + *data_type;
  return type;
}

std::string padded(const std::string& text, std::size_t width) {
  return text + std::string(width > text.size() ? width - text.size() : 0, ' ');
}

std::string plural(std::size_t n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

const char* kind_name(RTC::ExecutionKind kind) {
  switch (kind) {
    case RTC::PERIODIC:
      return "periodic";
    case RTC::EVENT_DRIVEN:
      return "event-driven";
    default:
      return "other";
  }
}

// ---- ls ----------------------------------------------------------------------------------

// The state of the component bound at `path` and, if asked, one line per port. Whatever goes
// wrong with this one object is shown in place of its state; the listing goes on.
std::string component_summary(Session& session, const std::string& path, bool with_ports,
                              std::vector<std::string>& port_lines) {
  RTC::RTObject_var component;
  std::string state;
  try {
    CORBA::Object_var object = session.naming().resolve(path);
    component = RTC::RTObject::_narrow(object);
    if (CORBA::is_nil(component)) return "not an RT-Component";
    state = rtc::state_name(rtc::component_state(component));
  } catch (const CORBA::SystemException& e) {
    // "unreachable", or "reported an error (...)" for a component that answers.
    const std::string why = reason(e, component);
    return why.compare(0, 11, "unreachable") == 0 ? "unreachable" : why;
  } catch (const rtc::NamingError&) {
    return "no longer bound";
  }
  if (!with_ports) return state;
  // The component answers: whatever fails now is one port's failure (e.g. a foreign port that
  // cannot reach a dead peer), shown on that port's line.
  RTC::PortServiceList_var ports;
  try {
    ports = component->get_ports();
  } catch (const CORBA::SystemException& e) {
    port_lines.push_back("ports: " + reason(e, component));
    return state;
  }
  struct Line {
    std::string name, type, tail;
  };
  std::vector<Line> lines;
  std::size_t name_width = 0;
  std::size_t type_width = 0;
  for (CORBA::ULong i = 0; i < ports->length(); ++i) {
    try {
      RTC::PortProfile_var profile = ports[i]->get_port_profile();
      lines.push_back({short_port_name(profile->name.in()), port_type(profile.in()),
                       plural(profile->connector_profiles.length(), "connection")});
    } catch (const CORBA::SystemException& e) {
      lines.push_back({"port " + std::to_string(i), "-", "no profile: " + reason(e, ports[i])});
    }
    name_width = std::max(name_width, lines.back().name.size());
    type_width = std::max(type_width, lines.back().type.size());
  }
  for (const Line& line : lines) {
    port_lines.push_back(padded(line.name, name_width) + "  " + padded(line.type, type_width) + "  " + line.tail);
  }
  return state;
}

void print_object(Session& session, const rtc::NamingClient::Entry& entry, const std::string& label, std::size_t width,
                  const std::string& indent, bool with_ports) {
  if (entry.kind != "rtc") {
    std::cout << indent << label << "\n";
    return;
  }
  std::vector<std::string> port_lines;
  const std::string summary = component_summary(session, entry.path, with_ports, port_lines);
  std::cout << indent << padded(label, width) << "  " << summary << "\n";
  for (const std::string& line : port_lines) std::cout << indent << "    " << line << "\n";
}

std::vector<rtc::NamingClient::Entry> sorted_bindings(Session& session, const std::string& context) {
  std::vector<rtc::NamingClient::Entry> entries = session.naming().list(context);
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.path < b.path; });
  return entries;
}

// A context that cannot be listed (one kept by another naming server that is gone) is marked in
// place, as a dead object is.
void print_tree(Session& session, const std::vector<rtc::NamingClient::Entry>& entries, const std::string& indent,
                bool with_ports) {
  std::size_t width = 0;
  for (const auto& entry : entries) width = std::max(width, leaf_name(entry).size());
  for (const auto& entry : entries) {
    if (!entry.is_context) {
      print_object(session, entry, leaf_name(entry), width, indent, with_ports);
      continue;
    }
    std::vector<rtc::NamingClient::Entry> children;
    try {
      children = sorted_bindings(session, entry.path);
    } catch (const rtc::NamingError&) {
      std::cout << indent << leaf_name(entry) << "/  unreachable\n";
      continue;
    }
    std::cout << indent << leaf_name(entry) << "/\n";
    print_tree(session, children, indent + "  ", with_ports);
  }
}

int list(Session& session, const std::string& path, bool with_ports) {
  if (path.empty()) {
    print_tree(session, sorted_bindings(session, ""), "", with_ports);
    return kOk;
  }
  // Whether PATH is a context or an object is the binding's type, read from its parent's
  // listing: asking the object itself would fail for a stale binding.
  const auto slash = path.rfind('/');
  const std::string parent = slash == std::string::npos ? "" : path.substr(0, slash);
  std::vector<rtc::NamingClient::Entry> siblings;
  try {
    siblings = session.naming().list(parent);
  } catch (const rtc::NamingUnreachable&) {
    throw;
  } catch (const rtc::NamingError& e) {
    throw Failure(kFailed, e.what());
  }
  const auto found = std::find_if(siblings.begin(), siblings.end(), [&](const auto& e) { return e.path == path; });
  if (found == siblings.end()) throw Failure(kFailed, path + ": not bound");
  if (found->is_context) {
    print_tree(session, sorted_bindings(session, path), "", with_ports);
  } else {
    print_object(session, *found, path, 0, "", with_ports);
  }
  return kOk;
}

// ---- cat ---------------------------------------------------------------------------------

void print_properties(const SDOPackage::NVList& properties, const std::string& indent) {
  if (properties.length() == 0) return;
  std::cout << indent << "properties:\n";
  for (const std::string& line : rtc::nv_lines(properties)) std::cout << indent << "  " << line << "\n";
}

std::string port_name_of(RTC::PortService_ptr port) {
  try {
    RTC::PortProfile_var profile = port->get_port_profile();
    return profile->name.in();
  } catch (const CORBA::SystemException& e) {
    return "<" + reason(e) + ">";
  }
}

void print_port(const RTC::PortProfile& port, const std::string& indent) {
  std::cout << indent << port.name.in() << "  " << port_type(port) << "\n";
  const std::string inner = indent + "  ";
  if (port.interfaces.length() > 0) std::cout << inner << "interfaces:\n";
  for (CORBA::ULong i = 0; i < port.interfaces.length(); ++i) {
    const RTC::PortInterfaceProfile& interface = port.interfaces[i];
    std::cout << inner << "  " << (interface.polarity == RTC::PROVIDED ? "provided" : "required") << "  "
              << interface.type_name.in() << "  " << interface.instance_name.in() << "\n";
  }
  print_properties(port.properties, inner);
  std::cout << inner << plural(port.connector_profiles.length(), "connection")
            << (port.connector_profiles.length() > 0 ? ":" : "") << "\n";
  for (CORBA::ULong i = 0; i < port.connector_profiles.length(); ++i) {
    const RTC::ConnectorProfile& connector = port.connector_profiles[i];
    std::cout << inner << "  " << connector.connector_id.in() << "  name: " << connector.name.in() << "\n";
    std::string peers;
    for (CORBA::ULong j = 0; j < connector.ports.length(); ++j) {
      peers += (j > 0 ? ", " : "") + port_name_of(connector.ports[j]);
    }
    std::cout << inner << "    ports: " << peers << "\n";
    print_properties(connector.properties, inner + "    ");
  }
}

void print_contexts(RTC::RTObject_ptr target, const RTC::ExecutionContextList& contexts, const char* relation,
                    const std::string& indent) {
  for (CORBA::ULong i = 0; i < contexts.length(); ++i) {
    std::cout << indent << relation << " " << i << ": ";
    try {
      std::ostringstream line;
      line << kind_name(contexts[i]->get_kind()) << ", " << contexts[i]->get_rate() << " Hz, "
           << rtc::state_name(contexts[i]->get_component_state(target));
      std::cout << line.str() << "\n";
    } catch (const CORBA::SystemException& e) {
      std::cout << reason(e) << "\n";
    }
  }
}

// The active configuration set, as rtcat shows it. A component without the SDO Configuration
// interface (it may raise InterfaceNotImplemented or NotAvailable) shows none.
void print_configuration(RTC::RTObject_ptr target) {
  try {
    SDOPackage::Configuration_var configuration = target->get_configuration();
    if (CORBA::is_nil(configuration)) return;
    SDOPackage::ConfigurationSet_var active = configuration->get_active_configuration_set();
    std::cout << "  configuration set " << active->id.in() << " (active):";
    if (active->configuration_data.length() == 0) std::cout << " no parameters";
    std::cout << "\n";
    for (const std::string& line : rtc::nv_lines(active->configuration_data)) std::cout << "    " << line << "\n";
  } catch (const CORBA::UserException&) {
  }
}

int cat_component(Session& session, const std::string& path) {
  RTC::RTObject_var target = session.component(path);
  calling(
      path,
      [&] {
        RTC::ComponentProfile_var profile = target->get_component_profile();
        RTC::ExecutionContextList_var owned = target->get_owned_contexts();
        RTC::ExecutionContextList_var participating = target->get_participating_contexts();
        RTC::PortServiceList_var ports = target->get_ports();
        // A port that fails (e.g. a foreign port that cannot reach a dead peer) is shown as such.
        std::vector<RTC::PortProfile_var> port_profiles;
        std::vector<std::string> port_failures;
        for (CORBA::ULong i = 0; i < ports->length(); ++i) {
          try {
            port_profiles.emplace_back(ports[i]->get_port_profile());
          } catch (const CORBA::SystemException& e) {
            port_failures.push_back("port " + std::to_string(i) + ": no profile: " + reason(e, ports[i]));
          }
        }
        const std::string state = rtc::state_name(rtc::component_state(target));

        std::cout << path << "  " << state << "\n";
        const std::pair<const char*, const char*> fields[] = {
            {"instance", profile->instance_name.in()},  {"type", profile->type_name.in()},
            {"description", profile->description.in()}, {"vendor", profile->vendor.in()},
            {"version", profile->version.in()},         {"category", profile->category.in()},
        };
        for (const auto& [name, value] : fields)
          std::cout << "  " << padded(std::string(name) + ":", 13) << value << "\n";
        std::cout << "  execution contexts:\n";
        print_contexts(target, owned.in(), "owned", "    ");
        print_contexts(target, participating.in(), "participating", "    ");
        print_properties(profile->properties, "  ");
        print_configuration(target);
        const std::size_t port_count = port_profiles.size() + port_failures.size();
        std::cout << "  " << plural(port_count, "port") << (port_count == 0 ? "" : ":") << "\n";
        for (const auto& port : port_profiles) print_port(port.in(), "    ");
        for (const auto& failure : port_failures) std::cout << "    " << failure << "\n";
      },
      target);
  return kOk;
}

int cat(Session& session, const std::string& target) {
  // A ':' marks PATH:PORT; a plain naming path holds none.
  if (target.find(':') == std::string::npos) {
    return cat_component(session, normalize_path(target));
  }
  const PortAddress address = parse_port_address(target);
  RTC::PortService_var port = session.port(address);
  RTC::PortProfile_var profile = calling(target, [&] { return port->get_port_profile(); });
  print_port(profile.in(), "");
  return kOk;
}

// ---- act / deact / reset -------------------------------------------------------------------

RTC::ReturnCode_t transition(const std::string& command, RTC::ExecutionContext_ptr context, RTC::RTObject_ptr target) {
  if (command == "act") return context->activate_component(target);
  if (command == "deact") return context->deactivate_component(target);
  return context->reset_component(target);
}

// Applies the command's transition to each component in its first owned context; every path is
// tried and each failure reported on its own line.
int change_state(Session& session, const std::string& command, const std::vector<std::string>& paths) {
  int rc = kOk;
  for (const std::string& given : paths) {
    const std::string path = normalize_path(given);
    try {
      RTC::RTObject_var target = session.component(path);
      const RTC::ReturnCode_t code = calling(path, [&] {
        RTC::ExecutionContextList_var contexts = target->get_owned_contexts();
        if (contexts->length() == 0 || CORBA::is_nil(contexts[0])) {
          throw Failure(kFailed, path + ": owns no execution context");
        }
        return transition(command, contexts[0], target);
      });
      if (code != RTC::RTC_OK) throw Failure(kFailed, path + ": " + rtc::return_code_name(code));
    } catch (const Failure& failure) {
      std::cerr << "urs: rtc " << command << ": " << failure.what() << "\n";
      rc = std::max(rc, failure.code());
    }
  }
  return rc;
}

// ---- con / dis -----------------------------------------------------------------------------

SDOPackage::NVList parse_properties(const std::vector<std::string>& pairs) {
  std::vector<std::pair<std::string, std::string>> parsed;
  for (const std::string& pair : pairs) {
    const auto equals = pair.find('=');
    if (equals == std::string::npos || equals == 0) {
      throw Failure(kUsage, "connector property '" + pair + "' is not key=value");
    }
    parsed.emplace_back(pair.substr(0, equals), pair.substr(equals + 1));
  }
  return rtc::nv_from(parsed);
}

int connect(Session& session, const std::string& first, const std::string& second,
            const std::vector<std::string>& properties, std::string name, const std::string& id, bool force) {
  const PortAddress first_address = parse_port_address(first);
  const PortAddress second_address = parse_port_address(second);
  const SDOPackage::NVList extra = parse_properties(properties);
  RTC::PortService_var a = session.port(first_address);
  RTC::PortService_var b = session.port(second_address);
  const std::string what = first + " " + second;
  // Ports that cannot work together (another interface or data type) are refused before any
  // call that would change them, unless the user insists.
  if (!force) {
    RTC::PortProfile_var a_profile = calling(
        first, [&] { return a->get_port_profile(); }, a);
    RTC::PortProfile_var b_profile = calling(
        second, [&] { return b->get_port_profile(); }, b);
    const std::string mismatch = rtc::connection_mismatch(a_profile.in(), b_profile.in());
    if (!mismatch.empty()) throw Failure(kFailed, mismatch + " (--force connects them anyway)");
  }
  // Without --name the connector is named after the ports it joins.
  if (name.empty()) name = port_name_of(a) + "_" + port_name_of(b);
  const rtc::Connection connection = calling(what, [&] {
    return rtc::connect_ports({a.in(), b.in()}, name, extra, id);
  });
  if (connection.code != RTC::RTC_OK) throw Failure(kFailed, what + ": " + rtc::return_code_name(connection.code));
  std::cout << connection.profile.connector_id.in() << "\n";
  return kOk;
}

int disconnect(Session& session, const std::string& first, const std::string& second, bool all) {
  if (all == !second.empty()) throw Failure(kUsage, "give a second PORT or --all (exactly one)");
  const PortAddress first_address = parse_port_address(first);
  const PortAddress second_address = all ? PortAddress{} : parse_port_address(second);
  RTC::PortService_var a = session.port(first_address);
  if (all) {
    const RTC::ReturnCode_t code = calling(first, [&] { return a->disconnect_all(); });
    if (code != RTC::RTC_OK) throw Failure(kFailed, first + ": " + rtc::return_code_name(code));
    return kOk;
  }
  RTC::PortService_var b = session.port(second_address);
  const int count = calling(first, [&] { return rtc::disconnect_ports(a, b); });
  if (count == 0) throw Failure(kFailed, first + " and " + second + " are not connected");
  return kOk;
}

// ---- call: an RT consumer of any provider port, from the interface's description -------------

struct CallRequest {
  std::string target;  // PATH:PORT
  std::string operation;
  std::string arguments;  // JSON; empty = {}
  std::string interface;  // the provided type_name to use; empty = the port's only one
  std::vector<std::string> idl_files;
  std::chrono::milliseconds deadline;
  bool show_trace = false;  // its trace id on stderr even when the call succeeds
};

int call(Session& session, const CallRequest& call) {
  const PortAddress address = parse_port_address(call.target);
  RTC::PortService_var port = session.port(address);
  RTC::PortProfile_var port_profile = calling(call.target, [&] { return port->get_port_profile(); });
  bool provides = false;
  for (CORBA::ULong i = 0; i < port_profile->interfaces.length(); ++i) {
    provides = provides || port_profile->interfaces[i].polarity == RTC::PROVIDED;
  }
  if (!provides) {
    throw Failure(kFailed, call.target + ": provides no interface (a " + port_type(port_profile.in()) + " port)");
  }
  schema::InterfaceCatalog catalog;
  for (const auto& file : call.idl_files) {
    try {
      catalog.load_idl(file, {});
    } catch (const std::exception& e) {
      throw Failure(kUsage, file + ": " + e.what());
    }
  }
  const rt_call::ProviderTarget target =
      calling(call.target, [&] { return rt_call::provider_target(port, catalog, call.interface, call.target); });
  if (!target.error.empty()) throw Failure(kFailed, target.error);
  const auto* interface = target.interface;
  const auto* method = interface->FindMethodByName(call.operation);
  if (method == nullptr) {
    std::string names;
    for (int i = 0; i < interface->method_count(); ++i) names += (i ? ", " : "") + interface->method(i)->name();
    throw Failure(kUsage, target.type_name + " has no operation '" + call.operation + "' (" + names + ")");
  }
  google::protobuf::DynamicMessageFactory factory;
  std::unique_ptr<google::protobuf::Message> request(factory.GetPrototype(method->input_type())->New());
  std::unique_ptr<google::protobuf::Message> reply(factory.GetPrototype(method->output_type())->New());
  const std::string error = schema::json_to_message(call.arguments.empty() ? "{}" : call.arguments, *request);
  if (!error.empty()) throw Failure(kUsage, call.operation + ": " + error);

  // The call's trace, in the request's service context (docs/rtc.md, "Trace context"); its id on
  // stderr (util::show_trace_id), so that stdout stays the reply alone.
  const auto trace = util::TraceContext::start();
  util::TraceScope scope(trace);
  const rt_call::ProviderOutcome outcome =
      rt_call::call_provider(session.orb(), target, *method, *request, *reply, call.deadline, call.target);
  util::show_trace_id(trace, call.show_trace || outcome.status != call::Status::OK);
  std::string json;
  if (outcome.status == call::Status::OK) {
    schema::message_to_json(*reply, json);
    std::cout << json << "\n";
    return kOk;
  }
  std::cerr << "urs: rtc call: " << call.target << "." << call.operation << ": " << call::status_name(outcome.status);
  if (!outcome.exception_type.empty()) std::cerr << " " << outcome.exception_type << " " << outcome.exception_json;
  if (!outcome.message.empty()) std::cerr << ": " << outcome.message;
  std::cerr << "\n";
  return outcome.status == call::Status::BAD_ARGUMENTS ? kUsage
         : outcome.status == call::Status::UNAVAILABLE ? kUnreachable
                                                       : kFailed;
}

}  // namespace

RtcCommands::RtcCommands(CLI::App& app) {
  rtc_ = app.add_subcommand("rtc", "Browse and drive RT-Components in a naming service (rtshell-like)");
  rtc_->require_subcommand(1);
  // Lets the options of `rtc` follow its subcommand too: `urs rtc ls --naming HOST:PORT`.
  rtc_->fallthrough();
  naming_ = "127.0.0.1:2809";
  rtc_->add_option("--naming", naming_, "Naming service HOST:PORT")->envname("URS_NAMING")->capture_default_str();
  rtc_->add_option("--call-timeout-ms", call_timeout_ms_, "Bound on every CORBA call")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();

  ls_ = rtc_->add_subcommand("ls", "Tree of the naming service under PATH, with component states");
  ls_->add_option("path", path_, "Naming path (default: the root)");
  ls_->add_flag("-l,--long", long_, "Also list each component's ports");

  cat_ = rtc_->add_subcommand("cat", "Profile of the component PATH or of the port PATH:PORT");
  cat_->add_option("target", path_, "PATH or PATH:PORT")->required();

  auto transition = [&](const char* name, const char* help) {
    CLI::App* command = rtc_->add_subcommand(name, help);
    command->add_option("paths", paths_, "Naming paths of components")->required();
    return command;
  };
  act_ = transition("act", "Activate the components in their first owned execution context");
  deact_ = transition("deact", "Deactivate the components in their first owned execution context");
  reset_ = transition("reset", "Reset the components (from Error) in their first owned execution context");

  con_ = rtc_->add_subcommand("con", "Connect two ports; prints the connector id");
  con_->add_option("port", first_port_, "PATH:PORT")->required();
  con_->add_option("peer", second_port_, "PATH:PORT")->required();
  con_->add_option("properties", properties_, "Connector properties key=value");
  con_->add_option("--name", connector_name_, "Connector name (default: <port>_<peer>)");
  con_->add_option("--id", connector_id_, "Connector id (default: the port assigns a UUID)");
  con_->add_flag("--force", force_, "Connect even ports whose interfaces or data types differ");

  dis_ = rtc_->add_subcommand("dis", "Disconnect two ports, or every connection of one port with --all");
  dis_->add_option("port", first_port_, "PATH:PORT")->required();
  dis_->add_option("peer", second_port_, "PATH:PORT");
  dis_->add_flag("--all", all_, "Remove every connection of PORT");

  call_ = rtc_->add_subcommand("call", "Call OPERATION on the provider port PATH:PORT (arguments as JSON)");
  call_->add_option("port", first_port_, "PATH:PORT of a provider port")->required();
  call_->add_option("operation", operation_, "Operation (or _get_<attribute>)")->required();
  call_->add_option("arguments", arguments_, "JSON object of the in/inout arguments (default {})");
  call_->add_option("--interface", interface_, "The provided interface's type_name, if the port has several");
  call_->add_option("--idl", idl_files_, "IDL file of an interface not built in (repeatable)");
  call_->add_option("--deadline-ms", deadline_ms_, "Bound on the call")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();
  call_->add_flag("--show-trace", show_trace_,
                  "Print the call's trace id on stderr when it succeeds too (always when it fails or stderr is a "
                  "terminal)");

  conf_ = rtc_->add_subcommand("conf", "Read and change a component's configuration sets (rtconf-like)");
  conf_->require_subcommand(1);
  conf_ls_ = conf_->add_subcommand("ls", "Every configuration set of PATH with its parameters; the active one marked");
  conf_ls_->add_option("path", path_, "Naming path of a component")->required();
  conf_get_ = conf_->add_subcommand("get", "The value of parameter NAME (in the active set or --set)");
  conf_get_->add_option("path", path_, "Naming path of a component")->required();
  conf_get_->add_option("name", parameter_, "Parameter")->required();
  conf_get_->add_option("--set", set_, "Configuration set (default: the active one)");
  conf_set_ = conf_->add_subcommand(
      "set", "Set parameter NAME to VALUE (in the active set or --set); it takes effect at once in the active set");
  conf_set_->add_option("path", path_, "Naming path of a component")->required();
  conf_set_->add_option("name", parameter_, "Parameter")->required();
  conf_set_->add_option("value", value_, "New value")->required();
  conf_set_->add_option("--set", set_, "Configuration set (default: the active one)");
  conf_act_ = conf_->add_subcommand("act", "Make SET the active configuration set");
  conf_act_->add_option("path", path_, "Naming path of a component")->required();
  conf_act_->add_option("set", set_, "Configuration set")->required();
}

bool RtcCommands::selected() const { return rtc_->parsed(); }

int RtcCommands::run(const std::string& log_level) {
  const CLI::App* chosen = rtc_->get_subcommands().front();
  if (chosen == conf_) chosen = conf_->get_subcommands().front();
  const std::string command = (chosen->get_parent() == conf_ ? "conf " : "") + chosen->get_name();
  try {
    urs::util::init_logging("urs", log_level);
    urs::util::parse_endpoint(naming_, "--naming");
  } catch (const std::exception& e) {
    std::cerr << "urs: rtc: " << e.what() << "\n";
    return kUsage;
  }
  try {
    Session session(naming_, std::chrono::milliseconds(call_timeout_ms_));
    if (chosen == ls_) return list(session, normalize_path(path_), long_);
    if (chosen == cat_) return cat(session, path_);
    if (chosen == act_ || chosen == deact_ || chosen == reset_) return change_state(session, command, paths_);
    if (chosen == con_) {
      return connect(session, first_port_, second_port_, properties_, connector_name_, connector_id_, force_);
    }
    if (chosen == dis_) return disconnect(session, first_port_, second_port_, all_);
    if (chosen == conf_ls_) return conf_list(session, normalize_path(path_));
    if (chosen == conf_get_) return conf_get(session, normalize_path(path_), parameter_, set_);
    if (chosen == conf_set_) return conf_set(session, normalize_path(path_), parameter_, value_, set_);
    if (chosen == conf_act_) return conf_activate(session, normalize_path(path_), set_);
    if (chosen == call_) {
      return call(session, {first_port_, operation_, arguments_, interface_, idl_files_,
                            std::chrono::milliseconds(deadline_ms_), show_trace_});
    }
  } catch (const Failure& failure) {
    std::cerr << "urs: rtc " << command << ": " << failure.what() << "\n";
    return failure.code();
  } catch (const std::invalid_argument& e) {  // a malformed naming path
    std::cerr << "urs: rtc " << command << ": " << e.what() << "\n";
    return kUsage;
  } catch (const rtc::NamingUnreachable& e) {
    std::cerr << "urs: rtc " << command << ": " << e.what() << "\n";
    return kUnreachable;
  } catch (const rtc::NamingError& e) {
    std::cerr << "urs: rtc " << command << ": " << e.what() << "\n";
    return kFailed;
  } catch (const CORBA::Exception& e) {
    std::cerr << "urs: rtc " << command << ": " << rtc::describe(e) << "\n";
    return kFailed;
  }
  return kUsage;
}

}  // namespace urs::cli
