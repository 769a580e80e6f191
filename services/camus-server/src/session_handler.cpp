#include "urs/camus_server/session_handler.hpp"

#include <spdlog/spdlog.h>

#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/tasks_agent.hpp"
#include "urs/util/trace.hpp"

namespace urs::camus_server {
namespace {

// A callback sending what it is given to the session `weak` names, as the frame field that
// `field` (e.g. &planet::Frame::mutable_event) sets, while the session is open. It returns whether
// the session took the frame: false once it is gone.
template <typename Message>
auto send_to(std::weak_ptr<planet::Session> weak, Message* (planet::Frame::*field)()) {
  return [weak = std::move(weak), field](const Message& message) {
    auto session = weak.lock();
    if (!session) return false;
    planet::Frame out;
    *(out.*field)() = message;
    return session->send(std::move(out));
  };
}

}  // namespace

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
      input.privileged = session->identity().role >= planet::SAM;
      input.publisher = session->identity().session;
      input.publish_id = publish->publish_id();
      // A traceparent that is not valid is dropped, not stored or passed on.
      if (auto trace = util::TraceContext::parse(publish->traceparent())) input.traceparent = trace->traceparent();
      bus_.publish(std::move(input), send_to(weak, &planet::Frame::mutable_publish_ack));
      return;
    }
    case planet::Frame::kSubscribe:
      bus_.subscribe(session->id(), frame.subscribe(), send_to(weak, &planet::Frame::mutable_event),
                     send_to(weak, &planet::Frame::mutable_subscribe_ack),
                     planet::ShareHolder{session->identity().name, session->identity().role >= planet::SAM});
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
