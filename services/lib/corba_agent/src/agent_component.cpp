#include "urs/corba_agent/agent_component.hpp"

#include <spdlog/spdlog.h>

#include <cctype>
#include <map>
#include <set>

#include "urs/agent/tunable.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"
#include "urs_options.pb.h"

namespace urs::corba_agent {

using google::protobuf::Descriptor;

namespace {

std::string repository_id_of(const Descriptor& type) {
  const std::string id = type.options().GetExtension(urs::options::message_repository_id);
  if (id.empty()) {
    throw std::invalid_argument(type.full_name() +
                                " is not an IDL struct, exception or union (it has no repository ID)");
  }
  return id;
}

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

}  // namespace

RawOutPort::RawOutPort(std::string name, const Descriptor& type)
    : OutPortBase(std::move(name), repository_id_of(type)), type_(type), codec_({&type}) {}

RawOutPort::WriteResult RawOutPort::write(const google::protobuf::Message& value) {
  if (value.GetDescriptor() != &type_) {
    throw std::invalid_argument("port " + name() + " carries " + type_.full_name() + ", not " +
                                value.GetDescriptor()->full_name());
  }
  return push([&](cdrStream& stream) { codec_.write(stream, value); });
}

RawInPort::RawInPort(std::string name, const Descriptor& type, Handler handler, std::size_t buffer_length)
    : InPortBase(std::move(name), repository_id_of(type), buffer_length),
      type_(type),
      codec_({&type}),
      handler_(std::move(handler)) {
  factory_.SetDelegateToGeneratedFactory(true);
}

RawInPort::~RawInPort() { detach(); }

void RawInPort::store(cdrMemoryStream& stream) {
  std::unique_ptr<google::protobuf::Message> value(factory_.GetPrototype(&type_)->New());
  codec_.read(stream, *value);
  expect_end(stream);
  count_received(false);
  if (!handler_) return;
  try {
    handler_(*value);
  } catch (const std::exception& e) {
    report_callback_error(e.what());
  }
}

// Events on configured topics go out through their port; others are logged at debug level.
class AgentComponent::Sink : public agent::EventSink {
 public:
  explicit Sink(AgentComponent& owner) : owner_(owner) {}

  void route(const std::string& topic, RawOutPort& port) { ports_[topic] = &port; }

  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    const auto it = ports_.find(topic);
    if (it == ports_.end()) {
      spdlog::debug("{}: event on topic '{}' ({}) has no port", owner_.instance_name(), topic,
                    event.GetDescriptor()->full_name());
      return call::Reply::success({});
    }
    try {
      it->second->write(event);
      return call::Reply::success({});
    } catch (const std::exception& e) {
      spdlog::warn("{}: event on topic '{}' not sent: {}", owner_.instance_name(), topic, e.what());
      return call::Reply::error(call::Status::BAD_ARGUMENTS, e.what());
    }
  }

 private:
  AgentComponent& owner_;
  std::map<std::string, RawOutPort*> ports_;  // written before the agent starts, then only read
};

AgentComponent::AgentComponent(AgentComponentConfig config, std::shared_ptr<agent::ServiceAgent> agent)
    : Component({config.type_name, agent->interface().full_name() + " provider hosting a service agent", "1.0.0",
                 "URSLink", agent->interface().name()}),
      config_(std::move(config)),
      agent_(std::move(agent)),
      sink_(std::make_unique<Sink>(*this)),
      port_(config_.port.empty() ? lower(agent_->interface().name()) : config_.port) {
  if (config_.port.empty()) config_.port = port_.name();
  if (config_.interface_instance.empty()) config_.interface_instance = config_.port;
  std::set<std::string> topics;
  std::set<std::string> port_names{config_.port};
  for (const auto& stream : config_.streams) {
    const Descriptor* type = agent_->interface().file()->pool()->FindMessageTypeByName(stream.type);
    if (type == nullptr) {
      throw std::invalid_argument("stream '" + stream.topic + "': no message type " + stream.type + " is known to " +
                                  agent_->interface().full_name());
    }
    if (!topics.insert(stream.topic).second)
      throw std::invalid_argument("topic '" + stream.topic + "' is streamed twice");
    if (!port_names.insert(stream.port).second) throw std::invalid_argument("port '" + stream.port + "' is used twice");
    out_ports_.push_back(std::make_unique<RawOutPort>(stream.port, *type));
    sink_->route(stream.topic, *out_ports_.back());
  }
}

AgentComponent::~AgentComponent() {
  if (started_) agent_->stop();
}

RawOutPort* AgentComponent::out_port(const std::string& name) {
  for (std::size_t i = 0; i < out_ports_.size(); ++i) {
    if (config_.streams[i].port == name) return out_ports_[i].get();
  }
  return nullptr;
}

RTC::ReturnCode_t AgentComponent::handle_initialize() {
  servant_ = std::make_unique<AgentServant>(orb().orb(), agent_, *sink_,
                                            AgentServantOptions{instance_name(), config_.deadline, config_.calls});
  agent_->start(*sink_);  // before the port makes the servant reachable
  started_ = true;
  port_.provide(config_.interface_instance, servant_->interface_name(), *servant_);
  add_port(port_);
  for (auto& port : out_ports_) add_port(*port);
  // The agent's tunable parameters become configuration parameters that tools may change.
  if (auto* tunable = dynamic_cast<agent::Tunable*>(agent_.get())) {
    for (const auto& parameter : tunable->tunable_parameters()) {
      declare_parameter(
          {parameter.name, parameter.value,
           [tunable, name = parameter.name](const std::string& value) { return tunable->check_parameter(name, value); },
           [tunable, name = parameter.name](const std::string& value) { tunable->set_parameter(name, value); }});
    }
  }
  return RTC::RTC_OK;
}

RTC::ReturnCode_t AgentComponent::handle_finalize() {
  if (started_) agent_->stop();
  started_ = false;
  return RTC::RTC_OK;
}

rtc::ComponentFactory agent_component_factory(
    std::string type_name, std::function<std::shared_ptr<agent::ServiceAgent>(const YAML::Node& params)> make_agent,
    call::CallRecorder* calls) {
  return [type_name = std::move(type_name), make_agent = std::move(make_agent), calls](
             const YAML::Node& config, const rtc::ComponentEnv&) -> std::unique_ptr<rtc::Component> {
    AgentComponentConfig settings;
    settings.type_name = type_name;
    settings.calls = calls;
    YAML::Node params;
    std::vector<std::string> errors;
    if (config && !config.IsNull()) {
      if (!config.IsMap()) throw util::ConfigError("config: a map is expected");
      util::check_keys(config, "config", {"params", "port", "interface_instance", "streams", "deadline_ms"}, errors);
      if (config["params"]) params = YAML::Clone(config["params"]);
      if (config["port"]) util::read_scalar(config["port"], "config.port", settings.port, errors);
      if (config["interface_instance"]) {
        util::read_scalar(config["interface_instance"], "config.interface_instance", settings.interface_instance,
                          errors);
      }
      if (config["deadline_ms"]) {
        std::uint32_t deadline_ms = 0;
        if (util::read_scalar(config["deadline_ms"], "config.deadline_ms", deadline_ms, errors) && deadline_ms == 0) {
          errors.push_back("config.deadline_ms: 0 is not a positive number of milliseconds");
        }
        if (deadline_ms > 0) settings.deadline = std::chrono::milliseconds(deadline_ms);
      }
      if (const auto streams = config["streams"]) {
        if (!streams.IsSequence()) errors.push_back("config.streams: a list is expected");
        for (std::size_t i = 0; streams.IsSequence() && i < streams.size(); ++i) {
          const std::string where = "config.streams[" + std::to_string(i) + "]";
          const YAML::Node stream = streams[i];
          if (!stream.IsMap()) {
            errors.push_back(where + ": a map is expected");
            continue;
          }
          util::check_keys(stream, where, {"topic", "port", "type"}, errors);
          EventStream entry;
          for (auto [key, out] : {std::pair{"topic", &entry.topic}, {"port", &entry.port}, {"type", &entry.type}}) {
            if (!stream[key]) {
              errors.push_back(where + "." + key + ": missing");
            } else {
              util::read_scalar(stream[key], where + "." + key, *out, errors);
            }
          }
          settings.streams.push_back(std::move(entry));
        }
      }
    }
    if (!errors.empty()) throw util::ConfigError(errors.front());
    std::shared_ptr<agent::ServiceAgent> agent = make_agent(params);
    try {
      return std::make_unique<AgentComponent>(std::move(settings), std::move(agent));
    } catch (const std::invalid_argument& e) {
      throw util::ConfigError(std::string("config.streams: ") + e.what());
    }
  };
}

}  // namespace urs::corba_agent
