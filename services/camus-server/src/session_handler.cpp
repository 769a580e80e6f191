#include "urs/camus_server/session_handler.hpp"

#include <spdlog/spdlog.h>

#include "urs/camus_server/context_store.hpp"

namespace urs::camus_server {

bool BuiltinServices::serves(const std::string& service) const {
  return service == RegistryService::kName || container_.hosts(service);
}

planet::Role BuiltinServices::required_role(const std::string& service, const std::string& operation) const {
  if (service == RegistryService::kName && (operation == "Register" || operation == "Unregister")) {
    return planet::SAM;
  }
  if (service == ContextAgent::kName && (operation == "Set" || operation == "Delete")) return planet::OPERATOR;
  if (service == TasksAgent::kName && (operation == "Define" || operation == "Run" || operation == "Cancel")) {
    return planet::OPERATOR;
  }
  return planet::CLIENT;
}

void BuiltinServices::dispatch(const Caller& caller, const planet::Request& request, Completion done) {
  if (request.service() == RegistryService::kName) {
    auto result = registry_.handle(caller.session, request);
    if (!request.oneway()) done(std::move(result));
    return;
  }
  container_.dispatch(request, caller, std::move(done));
}

void RouterInvoker::call(const std::string& caller, planet::Request request,
                         std::function<void(planet::CallResult)> done) {
  router_.call(Caller{nullptr, caller, planet::OPERATOR}, std::move(request), std::move(done));
}

void CamusSessionHandler::on_open(const planet::SessionPtr& session) {
  const auto& identity = session->identity();
  spdlog::info("connection {} opened: {} (role {}, session {}, peer '{}') from {}", session->id(), identity.name,
               planet::role_word(identity.role), identity.session, session->hello().peer_name(),
               session->remote_address());
}

void CamusSessionHandler::on_frame(const planet::SessionPtr& session, planet::Frame&& frame) {
  std::weak_ptr<planet::Session> weak = session;
  switch (frame.body_case()) {
    case planet::Frame::kRequest:
      router_.on_request(session, std::move(*frame.mutable_request()));
      return;
    case planet::Frame::kReply:
      router_.on_reply(*session, std::move(*frame.mutable_reply()));
      return;
    case planet::Frame::kPublish: {
      auto* publish = frame.mutable_publish();
      PublishInput input;
      input.topic = std::move(*publish->mutable_topic());
      input.payload = std::move(*publish->mutable_payload());
      input.content_type = std::move(*publish->mutable_content_type());
      input.source = session->identity().name;
      input.publisher = session->identity().session;
      input.publish_id = publish->publish_id();
      bus_.publish(std::move(input), [weak](const planet::PublishAck& ack) {
        auto s = weak.lock();
        if (!s) return;
        planet::Frame out;
        *out.mutable_publish_ack() = ack;
        s->send(std::move(out));
      });
      return;
    }
    case planet::Frame::kSubscribe:
      bus_.subscribe(
          session->id(), frame.subscribe(),
          [weak](const planet::Event& event) {
            auto s = weak.lock();
            if (!s) return false;
            planet::Frame out;
            *out.mutable_event() = event;
            return s->send(std::move(out));
          },
          [weak](const planet::SubscribeAck& ack) {
            auto s = weak.lock();
            if (!s) return;
            planet::Frame out;
            *out.mutable_subscribe_ack() = ack;
            s->send(std::move(out));
          });
      return;
    case planet::Frame::kUnsubscribe:
      bus_.unsubscribe(session->id(), frame.unsubscribe().subscription_id());
      return;
    default: {
      const auto* field = planet::Frame::descriptor()->FindFieldByNumber(frame.body_case());
      std::string kind = field != nullptr ? field->name() : "empty";
      spdlog::warn("connection {} ({}) sent an unexpected '{}' frame; closing it", session->id(),
                   session->identity().name, kind);
      session->close(planet::BAD_ARGUMENTS, "unexpected '" + kind + "' frame: a server does not accept it");
      return;
    }
  }
}

void CamusSessionHandler::on_close(const planet::SessionPtr& session, const std::string& reason) {
  spdlog::info("connection {} ({}) closed: {}", session->id(), session->identity().name, reason);
  registry_.remove_session(session->id());
  router_.on_session_closed(session->id());
  bus_.drop_owner(session->id());
}

}  // namespace urs::camus_server
