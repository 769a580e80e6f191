#include "urs/gateway/gateway.hpp"

#include <google/protobuf/util/json_util.h>
#include <spdlog/spdlog.h>

#include <cmath>

#include "urs/gateway/foxglove_json.hpp"
#include "urs/gateway/json_schema.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;
namespace fg = foxglove;

double unix_seconds(std::chrono::system_clock::time_point time) {
  return std::chrono::duration<double>(time.time_since_epoch()).count();
}
double unix_now() { return unix_seconds(std::chrono::system_clock::now()); }

Pose pose_of(const std::string& space, const std::string& robot, double x, double y, double theta,
             std::chrono::system_clock::time_point stamp, const char* via) {
  Pose pose;
  pose.set_space(space);
  pose.set_robot(robot);
  pose.set_x(x);
  pose.set_y(y);
  pose.set_theta(theta);
  pose.set_stamp(unix_seconds(stamp));
  pose.set_via(via);
  return pose;
}

namespace {

uint64_t stamp_ns(double seconds) { return seconds > 0 ? static_cast<uint64_t>(seconds * 1e9) : 0; }
uint64_t now_ns() { return stamp_ns(unix_now()); }

// What a channel carries: the message as the Foxglove side prints it (foxglove_json.hpp).
// `json` as a Value, or what it was when it cannot be kept: longer than `limit`, or not JSON.
void set_json(gp::Value& value, const std::string& json, std::size_t limit) {
  if (json.size() <= limit && gp::util::JsonStringToMessage(json, &value).ok()) return;
  auto& fields = *value.mutable_struct_value()->mutable_fields();
  fields.clear();
  fields["omitted"].set_string_value(json.size() > limit ? std::to_string(json.size()) + " bytes" : "not JSON");
}

std::string to_json(const gp::Message& message) {
  std::string json;
  const std::string error = to_foxglove_json(message, json);
  if (!error.empty()) spdlog::warn("gateway: {}", error);
  return json;
}

}  // namespace

Gateway::Gateway(GatewayOptions options, Hub& hub) : options_(std::move(options)), hub_(hub) {
  fixed("/graph", *Graph::descriptor(), Latch::keyed);
  fixed("/services", *Services::descriptor(), Latch::keyed);
  fixed("/components", *Components::descriptor(), Latch::keyed);
  fixed("/poses", *Pose::descriptor(), Latch::keyed);
  fixed("/trails", *Trail::descriptor(), Latch::keyed);
  fixed("/context", *ContextEntry::descriptor(), Latch::keyed);
  fixed("/events", *Event::descriptor(), Latch::history, options_.event_history);
  fixed("/calls", *Call::descriptor(), Latch::history, options_.call_history);
  std::lock_guard lock(mutex_);
  publish_snapshots();
}

Gateway::~Gateway() = default;

uint32_t Gateway::fixed(const std::string& topic, const gp::Descriptor& type, Latch latch, std::size_t history) {
  const uint32_t id = hub_.add_channel({topic, type.full_name(), json_schema(type), latch, history});
  fixed_[topic] = id;
  return id;
}

uint32_t Gateway::channel(const std::string& topic) const {
  auto it = fixed_.find(topic);
  return it == fixed_.end() ? 0 : it->second;
}

void Gateway::publish(uint32_t channel, const gp::Message& message, uint64_t stamp, const std::string& key,
                      bool removed) {
  hub_.publish(channel, std::make_shared<const std::string>(to_json(message)), stamp, key, removed);
}

// ---- services, components, operations: snapshots -------------------------------------------------

void Gateway::services(const std::string& source, std::vector<Service> now) {
  std::lock_guard lock(mutex_);
  services_[source] = std::move(now);
  publish_snapshots();
}

void Gateway::components(const std::string& source, std::vector<Component> now) {
  std::lock_guard lock(mutex_);
  components_[source] = std::move(now);
  publish_snapshots();
}

void Gateway::operations(const std::string& source, std::vector<Operation> now) {
  std::lock_guard lock(mutex_);
  operations_[source] = std::move(now);
  std::map<std::string, const Operation*> current;
  for (const auto& [from, list] : operations_) {
    for (const Operation& operation : list) current.emplace(operation.name, &operation);
  }
  for (auto it = offered_.begin(); it != offered_.end();) {
    if (!current.count(it->first)) {
      hub_.remove_service(it->second.id);
      it = offered_.erase(it);
    } else {
      ++it;
    }
  }
  for (const auto& [name, operation] : current) {
    if (operation->request == nullptr || operation->response == nullptr) continue;
    Offered wanted{0, operation->type, json_schema(*operation->request), json_schema(*operation->response)};
    auto it = offered_.find(name);
    if (it != offered_.end()) {
      if (it->second.type == wanted.type && it->second.request_schema == wanted.request_schema &&
          it->second.response_schema == wanted.response_schema) {
        continue;  // the same service: its id stays (the handler is looked up at each call)
      }
      hub_.remove_service(it->second.id);
      offered_.erase(it);
    }
    fg::Service service;
    service.name = name;
    service.type = operation->type;
    service.request = {"json", operation->request->full_name(), wanted.request_schema, "jsonschema"};
    service.response = {"json", operation->response->full_name(), wanted.response_schema, "jsonschema"};
    // The handler of the operation of that name now: a source may replace it without the
    // clients seeing the service leave and come back.
    wanted.id = hub_.add_service(std::move(service), [this, name = name](const Caller& caller, std::string json,
                                                                         std::function<void(CallReply)> reply) {
      serve(name, caller, std::move(json), std::move(reply));
    });
    offered_[name] = std::move(wanted);
  }
  publish_snapshots();
}

// One call of the operation `name`: the request and the reply converted between the Foxglove
// side's JSON and the canonical mapping the sources read and write; once answered, on /calls.
void Gateway::serve(const std::string& name, const Caller& caller, std::string json,
                    std::function<void(CallReply)> reply) {
  ServiceHandler handler;
  const gp::Descriptor* request = nullptr;
  const gp::Descriptor* response = nullptr;
  std::string type, space;
  {
    std::lock_guard lock(mutex_);
    for (const auto& [from, list] : operations_) {
      for (const Operation& candidate : list) {
        if (candidate.name != name) continue;
        handler = candidate.handler;
        request = candidate.request;
        response = candidate.response;
        type = candidate.type;
        space = candidate.space;
      }
    }
  }
  if (!handler || request == nullptr || response == nullptr) {
    reply(CallReply::failure("UNKNOWN_SERVICE: " + name + " is not offered any more"));
    return;
  }
  std::string canonical;
  const std::string error = from_foxglove_json(json.empty() ? "{}" : json, *request, canonical);
  if (!error.empty()) {
    reply(CallReply::failure("BAD_ARGUMENTS " + error));
    return;
  }
  auto record = std::make_shared<Call>();
  record->set_service(name);
  record->set_type(type);
  record->set_space(space);
  record->set_caller(caller.identity);
  record->set_role(role_name(caller.role));
  record->set_stamp(unix_now());
  set_json(*record->mutable_request(), json, options_.max_call_json);
  const auto started = std::chrono::steady_clock::now();
  handler(caller, std::move(canonical), [this, response, record, started, reply = std::move(reply)](CallReply outcome) {
    if (outcome.ok) {
      std::string printed;
      const std::string problem = to_foxglove_json(outcome.json, *response, printed);
      outcome = problem.empty() ? CallReply::success(std::move(printed)) : CallReply::failure("INTERNAL " + problem);
    }
    record->set_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    record->set_ok(outcome.ok);
    if (outcome.ok) {
      set_json(*record->mutable_reply(), outcome.json, options_.max_call_json);
    } else {
      record->set_error(outcome.error);
    }
    reply(std::move(outcome));
    call(*record);
  });
}

void Gateway::publish_snapshots() {
  std::map<std::pair<std::string, std::string>, std::vector<std::string>> callable;  // (space, service) -> ops
  for (const auto& [from, list] : operations_) {
    for (const Operation& operation : list) {
      if (offered_.count(operation.name)) callable[{operation.space, operation.service}].push_back(operation.name);
    }
  }
  Services services;
  for (const auto& [from, list] : services_) {
    for (Service service : list) {
      service.clear_operations();
      auto ops = callable.find({service.space(), service.name()});
      if (ops != callable.end()) {
        for (const auto& name : ops->second) service.add_operations(name);
      }
      *services.add_services() = std::move(service);
    }
  }
  std::string json = to_json(services);
  if (json != last_services_) {
    last_services_ = json;
    hub_.publish(fixed_.at("/services"), std::make_shared<const std::string>(std::move(json)), now_ns());
  }
  Components components;
  for (const auto& [from, list] : components_) {
    for (const Component& component : list) *components.add_components() = component;
  }
  json = to_json(components);
  if (json != last_components_) {
    last_components_ = json;
    hub_.publish(fixed_.at("/components"), std::make_shared<const std::string>(std::move(json)), now_ns());
  }
  publish_graph();
}

void Gateway::publish_graph() {
  struct Seen {
    std::set<std::string> middlewares;
    std::set<std::string> bridges;
    uint32_t services = 0;
    uint32_t components = 0;
  };
  std::map<std::string, Seen> spaces;
  spaces[options_.space].middlewares.insert(options_.middlewares.begin(), options_.middlewares.end());
  fg::GraphUpdate graph;
  std::map<std::string, std::set<std::string>> bridge_ids;  // "<space>:<bridge>"
  for (const auto& [from, list] : services_) {
    for (const Service& service : list) {
      Seen& seen = spaces[service.space()];
      ++seen.services;
      if (!service.bridge().empty()) seen.bridges.insert(service.bridge());
      const std::string& origin = service.origin();
      if (origin == "camus" || origin.rfind("camus:", 0) == 0) seen.middlewares.insert("camus");
      if (origin == "rtc" || origin.rfind("rtc:", 0) == 0) seen.middlewares.insert("rtc");
      fg::TopicNodes nodes{service.space() + "/" + service.name(), {}};
      nodes.ids.push_back(service.space() + ":" + (service.provider().empty() ? service.origin() : service.provider()));
      if (!service.bridge().empty()) nodes.ids.push_back(service.space() + ":" + service.bridge());
      graph.advertised_services.push_back(std::move(nodes));
    }
  }
  for (const auto& [from, list] : components_) {
    for (const Component& component : list) {
      Seen& seen = spaces[component.space()];
      ++seen.components;
      seen.middlewares.insert(component.kind() == "rtc" ? "rtc" : "camus");
    }
  }
  Graph message;
  message.set_space(options_.space);
  message.set_dds(options_.dds);
  message.set_dds_domain(options_.dds_domain);
  std::vector<std::string> all_bridges;
  std::vector<std::string> publishers;
  for (const auto& [name, seen] : spaces) {
    SpaceInfo* info = message.add_spaces();
    info->set_name(name);
    info->set_local(name == options_.space);
    for (const auto& middleware : seen.middlewares) info->add_middlewares(middleware);
    info->set_services(seen.services);
    info->set_components(seen.components);
    for (const auto& bridge : seen.bridges) {
      BridgeInfo* b = info->add_bridges();
      b->set_name(bridge);
      b->set_alive(true);
      all_bridges.push_back(name + ":" + bridge);
    }
    publishers.push_back("space:" + name);
  }
  // The gateway's channels are fed by the spaces; the DDS link's topics join the bridges.
  const std::string self = "urs-gateway:" + options_.space;
  for (const auto& [topic, id] : fixed_) {
    graph.published_topics.push_back({topic, publishers});
    graph.subscribed_topics.push_back({topic, {self}});
  }
  // Each robot's own channel, fed by the robot's space.
  for (const auto& [key, robot] : robots_) {
    if (robot.channel == 0) continue;
    const std::string topic = "/" + key + "/pose";
    graph.published_topics.push_back({topic, {"space:" + key.substr(0, key.find('/'))}});
    graph.subscribed_topics.push_back({topic, {self}});
  }
  if (options_.dds) {
    for (const char* topic : {"urs/catalog", "urs/interface", "urs/state/component", "urs/state/pose",
                              "urs/state/context", "urs/state/event"}) {
      const std::string name = "dds:" + std::string(topic);
      graph.published_topics.push_back({name, all_bridges});
      auto readers = all_bridges;
      readers.push_back(self);
      graph.subscribed_topics.push_back({name, readers});
    }
  }
  hub_.set_graph(graph);
  std::string json = to_json(message);
  if (json != last_graph_) {
    last_graph_ = json;
    hub_.publish(fixed_.at("/graph"), std::make_shared<const std::string>(std::move(json)), now_ns());
  }
}

// ---- streams ------------------------------------------------------------------------------------

void Gateway::pose(const Pose& pose) {
  const std::string key = pose.space() + "/" + pose.robot();
  const uint64_t stamp = stamp_ns(pose.stamp());
  auto json = std::make_shared<const std::string>(to_json(pose));
  hub_.publish(fixed_.at("/poses"), json, stamp, key);
  std::unique_lock lock(mutex_);
  auto it = robots_.find(key);
  if (it == robots_.end()) {
    if (robots_.size() >= options_.max_robots * 4) return;  // a flood of robot names: keep the known ones
    it = robots_.emplace(key, Robot{}).first;
    if (robots_.size() <= options_.max_robots) {
      it->second.channel = hub_.add_channel(
          {"/" + key + "/pose", Pose::descriptor()->full_name(), json_schema(*Pose::descriptor()), Latch::keyed, 0});
      publish_graph();  // the new channel joins the connection graph
    }
  }
  Robot& robot = it->second;
  if (robot.channel != 0) hub_.publish(robot.channel, json, stamp);
  auto& trail = robot.trail;
  if (trail.empty() ||
      std::hypot(trail.back().x() - pose.x(), trail.back().y() - pose.y()) >= options_.trail_spacing_m) {
    TrailPoint point;
    point.set_x(pose.x());
    point.set_y(pose.y());
    point.set_stamp(pose.stamp());
    trail.push_back(point);
    while (trail.size() > options_.trail_points) trail.pop_front();
  }
  const auto now = std::chrono::steady_clock::now();
  if (now - robot.trail_sent < options_.trail_period) return;
  robot.trail_sent = now;
  Trail message;
  message.set_space(pose.space());
  message.set_robot(pose.robot());
  for (const auto& point : trail) *message.add_points() = point;
  lock.unlock();
  publish(fixed_.at("/trails"), message, stamp, key);
}

void Gateway::context(const ContextEntry& entry) {
  publish(fixed_.at("/context"), entry, stamp_ns(entry.stamp() > 0 ? entry.stamp() : unix_now()),
          entry.space() + "/" + entry.key(), entry.removed());
}

void Gateway::call(const Call& call) {
  publish(fixed_.at("/calls"), call, stamp_ns(call.stamp() > 0 ? call.stamp() : unix_now()));
}

void Gateway::event(const Event& event) {
  publish(fixed_.at("/events"), event, stamp_ns(event.stamp() > 0 ? event.stamp() : unix_now()));
}

}  // namespace urs::gateway
