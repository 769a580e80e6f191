#include "urs/gateway/hub.hpp"

#include <spdlog/spdlog.h>

namespace urs::gateway {

namespace fg = foxglove;

const char* role_name(Role role) { return role == Role::operator_ ? "operator" : "viewer"; }

namespace {

std::map<std::string, std::vector<std::string>> by_name(const std::vector<fg::TopicNodes>& list) {
  std::map<std::string, std::vector<std::string>> out;
  for (const auto& nodes : list) out[nodes.name] = nodes.ids;
  return out;
}

// What changed from `before` to `now` in one list: entries new or different, and names gone.
void diff(const std::vector<fg::TopicNodes>& before, const std::vector<fg::TopicNodes>& now,
          std::vector<fg::TopicNodes>& changed, std::vector<std::string>* removed) {
  const auto old = by_name(before);
  const auto current = by_name(now);
  for (const auto& [name, ids] : current) {
    const auto it = old.find(name);
    if (it == old.end() || it->second != ids) changed.push_back({name, ids});
  }
  if (removed == nullptr) return;
  for (const auto& [name, ids] : old) {
    if (!current.count(name)) removed->push_back(name);
  }
}

}  // namespace

Hub::Hub(HubOptions options) : options_(std::move(options)) {}

uint32_t Hub::add_channel(ChannelSpec spec) {
  std::lock_guard lock(mutex_);
  const uint32_t id = next_channel_++;
  ChannelState& state = channels_[id];
  state.channel.id = id;
  state.channel.topic = std::move(spec.topic);
  state.channel.schema_name = std::move(spec.schema_name);
  state.channel.schema = std::move(spec.schema);
  state.latch = spec.latch;
  state.history = spec.history;
  const std::string message = fg::advertise({&state.channel});
  for (auto& [client_id, client] : clients_) client.outbox->send_text(message);
  return id;
}

void Hub::remove_channel(uint32_t id) {
  std::lock_guard lock(mutex_);
  auto it = channels_.find(id);
  if (it == channels_.end()) return;
  for (const auto& [client_id, subscription] : it->second.subscribers) {
    auto client = clients_.find(client_id);
    if (client != clients_.end()) client->second.subscriptions.erase(subscription);
  }
  channels_.erase(it);
  const std::string message = fg::unadvertise({id});
  for (auto& [client_id, client] : clients_) client.outbox->send_text(message);
}

void Hub::send_message(Client& client, uint32_t subscription, const Latched& message) {
  client.outbox->send_binary(fg::message_data_header(subscription, message.stamp_ns), message.payload);
}

void Hub::publish(uint32_t channel, std::shared_ptr<const std::string> payload, uint64_t stamp_ns,
                  const std::string& key, bool removed) {
  std::lock_guard lock(mutex_);
  auto it = channels_.find(channel);
  if (it == channels_.end()) return;
  ChannelState& state = it->second;
  const Latched message{std::move(payload), stamp_ns};
  switch (state.latch) {
    case Latch::none:
      break;
    case Latch::keyed:
      if (removed) {
        state.keyed.erase(key);
      } else if (state.keyed.count(key) || state.keyed.size() < options_.max_keys_per_channel) {
        state.keyed[key] = message;
      } else if (!state.full_reported) {
        state.full_reported = true;
        spdlog::warn(
            "gateway: channel {} holds {} keys; new keys (first '{}') are sent but not kept for later "
            "subscribers",
            state.channel.topic, state.keyed.size(), key);
      }
      break;
    case Latch::history:
      state.recent.push_back(message);
      while (state.recent.size() > state.history) state.recent.pop_front();
      break;
  }
  for (const auto& [client_id, subscription] : state.subscribers) {
    auto client = clients_.find(client_id);
    if (client != clients_.end()) send_message(client->second, subscription, message);
  }
}

uint32_t Hub::add_service(fg::Service service, ServiceHandler handler) {
  std::lock_guard lock(mutex_);
  const uint32_t id = next_service_++;
  service.id = id;
  ServiceState& state = services_[id];
  state.service = std::move(service);
  state.handler = std::move(handler);
  const std::string message = fg::advertise_services({&state.service});
  for (auto& [client_id, client] : clients_) client.outbox->send_text(message);
  return id;
}

void Hub::remove_service(uint32_t id) {
  std::lock_guard lock(mutex_);
  if (services_.erase(id) == 0) return;
  const std::string message = fg::unadvertise_services({id});
  for (auto& [client_id, client] : clients_) client.outbox->send_text(message);
}

void Hub::set_graph(const fg::GraphUpdate& graph) {
  std::lock_guard lock(mutex_);
  fg::GraphUpdate update;
  diff(graph_.published_topics, graph.published_topics, update.published_topics, &update.removed_topics);
  diff(graph_.subscribed_topics, graph.subscribed_topics, update.subscribed_topics, nullptr);
  diff(graph_.advertised_services, graph.advertised_services, update.advertised_services, &update.removed_services);
  // A topic only subscribed is removed when it leaves the subscribed list too.
  for (const auto& [name, ids] : by_name(graph_.subscribed_topics)) {
    bool still = false;
    for (const auto& nodes : graph.subscribed_topics) still = still || nodes.name == name;
    for (const auto& nodes : graph.published_topics) still = still || nodes.name == name;
    bool listed = false;
    for (const auto& removed : update.removed_topics) listed = listed || removed == name;
    if (!still && !listed) update.removed_topics.push_back(name);
  }
  graph_ = graph;
  if (update.empty()) return;
  const std::string message = fg::connection_graph_update(update);
  for (auto& [client_id, client] : clients_) {
    if (client.graph) client.outbox->send_text(message);
  }
}

std::vector<std::string> Hub::capabilities() const {
  std::vector<std::string> out{"services", "connectionGraph"};
  if (options_.client_publish) out.emplace_back("clientPublish");
  return out;
}

void Hub::set_publish_handler(PublishHandler handler) {
  std::lock_guard lock(mutex_);
  publish_handler_ = std::move(handler);
}

uint64_t Hub::connect(std::shared_ptr<Outbox> outbox, Role role, std::string login, std::string identity) {
  std::lock_guard lock(mutex_);
  const uint64_t id = next_client_++;
  Client& client = clients_[id];
  client.outbox = std::move(outbox);
  client.role = role;
  client.login = std::move(login);
  client.identity = std::move(identity);
  auto metadata = options_.metadata;
  metadata.emplace_back("role", role_name(role));
  client.outbox->send_text(fg::server_info(options_.name, capabilities(), {"json"}, metadata, options_.session_id));
  std::vector<const fg::Channel*> channels;
  for (const auto& [channel_id, state] : channels_) channels.push_back(&state.channel);
  client.outbox->send_text(fg::advertise(channels));  // at least one, even if empty
  std::vector<const fg::Service*> services;
  for (const auto& [service_id, state] : services_) services.push_back(&state.service);
  if (!services.empty()) client.outbox->send_text(fg::advertise_services(services));
  return id;
}

void Hub::disconnect(uint64_t id) {
  std::lock_guard lock(mutex_);
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  for (const auto& [subscription, channel] : it->second.subscriptions) {
    auto state = channels_.find(channel);
    if (state != channels_.end()) state->second.subscribers.erase(id);
  }
  clients_.erase(it);
}

void Hub::status(Client& client, fg::StatusLevel level, const std::string& message) {
  client.outbox->send_text(fg::status(level, message));
}

void Hub::receive_text(uint64_t id, std::string_view text) {
  fg::ClientMessage message = fg::parse_text(text);
  std::unique_lock lock(mutex_);
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  Client& client = it->second;
  if (auto* error = std::get_if<fg::ProtocolError>(&message)) {
    status(client, fg::StatusLevel::error, error->message);
  } else if (auto* unsupported = std::get_if<fg::Unsupported>(&message)) {
    std::string list;
    for (const auto& capability : capabilities()) list += (list.empty() ? "" : ", ") + capability;
    status(client, fg::StatusLevel::error,
           "'" + unsupported->op + "' is not supported by this server (capabilities: " + list + ")");
  } else if (auto* advertise_request = std::get_if<fg::ClientAdvertise>(&message)) {
    advertise(client, *advertise_request);
  } else if (auto* unadvertise_request = std::get_if<fg::ClientUnadvertise>(&message)) {
    unadvertise(client, *unadvertise_request);
  } else if (auto* subscribe_request = std::get_if<fg::Subscribe>(&message)) {
    subscribe(id, client, *subscribe_request);
  } else if (auto* unsubscribe_request = std::get_if<fg::Unsubscribe>(&message)) {
    unsubscribe(id, client, *unsubscribe_request);
  } else if (std::holds_alternative<fg::SubscribeConnectionGraph>(message)) {
    client.graph = true;
    fg::GraphUpdate everything = graph_;
    everything.removed_topics.clear();
    everything.removed_services.clear();
    client.outbox->send_text(fg::connection_graph_update(everything));
  } else if (std::holds_alternative<fg::UnsubscribeConnectionGraph>(message)) {
    client.graph = false;
  } else if (std::holds_alternative<fg::ServiceCallRequest>(message) ||
             std::holds_alternative<fg::ClientMessageData>(message)) {
    status(client, fg::StatusLevel::error, "a service call request or client message data is a binary message");
  }
}

void Hub::advertise(Client& client, const fg::ClientAdvertise& request) {
  if (!options_.client_publish) {
    status(client, fg::StatusLevel::error,
           "'advertise' is not supported by this server (clientPublish is offered only while playing a recording)");
    return;
  }
  if (client.role != Role::operator_) {
    status(client, fg::StatusLevel::error,
           std::string("PERMISSION_DENIED: publishing needs the operator role; this connection is ") +
               role_name(client.role));
    return;
  }
  for (const auto& channel : request.channels) {
    if (channel.encoding != "json") {
      status(client, fg::StatusLevel::error,
             "advertise: channel " + std::to_string(channel.id) + " (" + channel.topic + "): encoding '" +
                 channel.encoding + "' is not supported (supportedEncodings: json)");
    } else if (client.published.count(channel.id)) {
      status(client, fg::StatusLevel::error,
             "advertise: channel id " + std::to_string(channel.id) + " is in use (unadvertise it first)");
    } else if (client.published.size() >= options_.max_client_channels) {
      status(client, fg::StatusLevel::error,
             "advertise: at most " + std::to_string(options_.max_client_channels) + " channels per connection");
    } else {
      client.published[channel.id] = channel;
    }
  }
}

void Hub::unadvertise(Client& client, const fg::ClientUnadvertise& request) {
  for (uint32_t id : request.channel_ids) {
    if (client.published.erase(id) == 0) {
      status(client, fg::StatusLevel::warning, "unadvertise: no channel " + std::to_string(id));
    }
  }
}

void Hub::receive_binary(uint64_t id, std::string_view bytes) {
  fg::ClientMessage message = fg::parse_binary(bytes);
  std::unique_lock lock(mutex_);
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  Client& client = it->second;
  if (auto* request = std::get_if<fg::ServiceCallRequest>(&message)) {
    const uint32_t service_id = request->service_id;
    const uint32_t call_id = request->call_id;
    auto service = services_.find(service_id);
    std::string refusal;
    if (service == services_.end()) {
      refusal = "unknown service id " + std::to_string(service_id);
    } else if (request->encoding != "json") {
      refusal = "encoding '" + request->encoding.substr(0, fg::kMaxEncodingLength) +
                "' is not supported (supportedEncodings: json)";
    } else if (client.role != Role::operator_) {
      refusal = "PERMISSION_DENIED: " + service->second.service.name + " needs the operator role; this connection is " +
                role_name(client.role) + " (log in with a credential the CAMUS server gives the role operator)";
    } else if (client.calls_in_flight >= options_.max_calls_in_flight) {
      refusal =
          "too many calls in flight on this connection (at most " + std::to_string(options_.max_calls_in_flight) + ")";
    }
    if (!refusal.empty()) {
      client.outbox->send_text(fg::service_call_failure(service_id, call_id, refusal));
      return;
    }
    ++client.calls_in_flight;
    ServiceHandler handler = service->second.handler;
    const Caller caller{id, client.role, client.login, client.identity};
    lock.unlock();
    handler(caller, std::move(request->payload),
            [this, id, service_id, call_id](CallReply reply) { answer(id, service_id, call_id, reply); });
    return;
  }
  if (auto* data = std::get_if<fg::ClientMessageData>(&message)) {
    const auto channel = client.published.find(data->channel_id);
    if (!options_.client_publish) {
      status(client, fg::StatusLevel::error, "client message data is not supported by this server (no clientPublish)");
      return;
    }
    if (channel == client.published.end()) {
      status(client, fg::StatusLevel::error,
             "client message data: unknown channel " + std::to_string(data->channel_id) + " (advertise it first)");
      return;
    }
    const PublishHandler handler = publish_handler_;
    const Caller caller{id, client.role, client.login, client.identity};
    const std::string topic = channel->second.topic;
    const std::string schema_name = channel->second.schema_name;
    lock.unlock();
    std::string refusal =
        handler ? handler(caller, topic, schema_name, data->payload) : "nothing takes published messages";
    if (refusal.empty()) return;
    lock.lock();
    auto again = clients_.find(id);
    if (again != clients_.end()) status(again->second, fg::StatusLevel::error, topic + ": " + refusal);
    return;
  }
  if (auto* error = std::get_if<fg::ProtocolError>(&message)) {
    status(client, fg::StatusLevel::error, error->message);
  } else if (auto* unsupported = std::get_if<fg::Unsupported>(&message)) {
    status(client, fg::StatusLevel::error, "'" + unsupported->op + "' is not supported by this server");
  }
}

void Hub::answer(uint64_t id, uint32_t service_id, uint32_t call_id, const CallReply& reply) {
  std::lock_guard lock(mutex_);
  auto it = clients_.find(id);
  if (it == clients_.end()) return;  // the caller left
  Client& client = it->second;
  if (client.calls_in_flight > 0) --client.calls_in_flight;
  if (reply.ok) {
    client.outbox->send_binary(fg::service_call_response(service_id, call_id, "json", reply.json), nullptr);
  } else {
    client.outbox->send_text(fg::service_call_failure(service_id, call_id, reply.error));
  }
}

void Hub::subscribe(uint64_t id, Client& client, const fg::Subscribe& request) {
  for (const auto& wanted : request.subscriptions) {
    auto channel = channels_.find(wanted.channel_id);
    if (client.subscriptions.count(wanted.id)) {
      status(client, fg::StatusLevel::error,
             "subscribe: subscription id " + std::to_string(wanted.id) + " is in use (unsubscribe it first)");
      continue;
    }
    if (channel == channels_.end()) {
      status(client, fg::StatusLevel::error, "subscribe: unknown channel " + std::to_string(wanted.channel_id));
      continue;
    }
    ChannelState& state = channel->second;
    if (state.subscribers.count(id)) {
      status(client, fg::StatusLevel::error,
             "subscribe: channel " + std::to_string(wanted.channel_id) + " (" + state.channel.topic +
                 ") is subscribed already with id " + std::to_string(state.subscribers.at(id)));
      continue;
    }
    if (client.subscriptions.size() >= options_.max_subscriptions) {
      status(client, fg::StatusLevel::error,
             "subscribe: at most " + std::to_string(options_.max_subscriptions) + " subscriptions per connection");
      continue;
    }
    client.subscriptions[wanted.id] = wanted.channel_id;
    state.subscribers[id] = wanted.id;
    for (const auto& [key, message] : state.keyed) send_message(client, wanted.id, message);
    for (const auto& message : state.recent) send_message(client, wanted.id, message);
  }
}

void Hub::unsubscribe(uint64_t id, Client& client, const fg::Unsubscribe& request) {
  for (uint32_t subscription : request.subscription_ids) {
    auto it = client.subscriptions.find(subscription);
    if (it == client.subscriptions.end()) {
      status(client, fg::StatusLevel::warning, "unsubscribe: no subscription " + std::to_string(subscription));
      continue;
    }
    auto channel = channels_.find(it->second);
    if (channel != channels_.end()) channel->second.subscribers.erase(id);
    client.subscriptions.erase(it);
  }
}

std::size_t Hub::clients() const {
  std::lock_guard lock(mutex_);
  return clients_.size();
}

std::size_t Hub::subscribers(uint32_t channel) const {
  std::lock_guard lock(mutex_);
  auto it = channels_.find(channel);
  return it == channels_.end() ? 0 : it->second.subscribers.size();
}

}  // namespace urs::gateway
