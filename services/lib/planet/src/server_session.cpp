#include "server_session.hpp"

#include <spdlog/spdlog.h>

#include <exception>
#include <utility>

#include "urs/planet/authenticator.hpp"
#include "urs/planet/status.hpp"

namespace urs::planet {

namespace {

constexpr size_t kMaxPeerNameBytes = 128;

// Empty if `name` is an acceptable Hello.peer_name, else why not. Letters are ASCII letters.
std::string peer_name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > kMaxPeerNameBytes) {
    return "it is " + std::to_string(name.size()) + " bytes long; the limit is " + std::to_string(kMaxPeerNameBytes);
  }
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-' || c == '@' || c == ':' || c == '/';
    if (!ok) return "it holds a character other than letters, digits and . _ - @ : /";
  }
  if (name == "camus-server") return "'camus-server' is the server's own name";
  return {};
}

}  // namespace

void ServerSession::begin() {
  auto self = std::static_pointer_cast<ServerSession>(shared_from_this());
  asio::post(executor(), [self] {
    if (self->closing()) return;  // Server::stop() got here first
    self->handshake_timer_.expires_after(self->server_.options.handshake_timeout);
    self->handshake_timer_.async_wait([self](const std::error_code& error) {
      if (error || self->opened_) return;
      const std::string reason =
          "no Hello within " + std::to_string(self->server_.options.handshake_timeout.count()) + " ms";
      detail::warn_peer(self->peer_address(), "closing " + self->describe() + ": " + reason);
      self->server_.refusals.count("handshake_timeout");
      self->close_link(detail::make_goodbye(Status::DEADLINE_EXCEEDED, reason), reason);
    });
    self->start();
  });
}

void ServerSession::handle_frame(Frame&& frame) {
  if (!opened_) {
    handshake(std::move(frame));
    return;
  }
  if (frame.has_hello()) {
    protocol_violation("unexpected Hello: the session is already open");
    return;
  }
  if (frame.has_publish() && refuse_resent_publish(frame.publish())) return;
  server_.handler.on_frame(self(), std::move(frame));
}

bool ServerSession::refuse_resent_publish(const Publish& publish) {
  const uint64_t id = publish.publish_id();
  publish_through_ = std::max(publish_through_, id);
  if (id == 0 || id > forgotten_publish_through_) return false;
  Frame ack;
  ack.mutable_publish_ack()->set_publish_id(id);
  ack.mutable_publish_ack()->set_status(Status::ALREADY_EXISTS);
  ack.mutable_publish_ack()->set_message(
      "publish_id " + std::to_string(id) + " was received by session " + std::to_string(forgotten_session_) +
      ", which this server no longer keeps (evicted, or closed longer than it keeps sessions resumable); it was "
      "accepted or refused then and is not delivered again");
  enqueue(std::move(ack));
  return true;
}

void ServerSession::handle_closed(const std::string& reason) {
  handshake_timer_.cancel();
  if (opened_) {
    server_.session_share->give(holder_, 1);
    server_.directory.closed(identity_.session, this, publish_through_);
    spdlog::info("planet: {} closed: {}", describe(), reason);
    try {
      server_.handler.on_close(self(), reason);
    } catch (const std::exception& exception) {
      spdlog::error("planet: SessionHandler::on_close of {} threw: {}", describe(), exception.what());
    }
  }
  server_.on_session_closed(id_);
}

std::string ServerSession::describe() const {
  std::string text = "session " + std::to_string(id_) + " from " + peer_address();
  if (opened_) text += " (" + identity_.name + ", peer '" + hello_.peer_name() + "')";
  return text;
}

void ServerSession::handle_protocol_error(const ProtocolError& error) {
  server_.protocol_errors.count(std::string(protocol_error_name(error.code())));
  switch (error.code()) {
    case ProtocolErrorCode::kFrameTooLarge:
      server_.refusals.count(opened_ ? "chunk_bytes" : "max_hello_bytes");
      break;
    case ProtocolErrorCode::kMessageTooLarge:
      server_.refusals.count("max_message_bytes");
      break;
    case ProtocolErrorCode::kReassemblyLimit:
      server_.refusals.count("max_reassembly_bytes");
      break;
    case ProtocolErrorCode::kTooManyPartialMessages:
      server_.refusals.count("max_partial_messages");
      break;
    default:  // kServerBudget: counted by the buffer share that refused
      break;
  }
  Link::handle_protocol_error(error);
}

void ServerSession::protocol_violation(const std::string& reason) {
  server_.protocol_errors.count(opened_ ? "UNEXPECTED_FRAME" : "BAD_HELLO");
  detail::warn_peer(peer_address(), "closing " + describe() + ": " + reason);
  close_link(detail::make_goodbye(Status::BAD_ARGUMENTS, reason), reason);
}

void ServerSession::refuse(Status status, const std::string& reason, const Hello& hello) {
  const bool printable = peer_name_problem(hello.peer_name()).empty();
  detail::warn_peer(peer_address(), "refused peer '" + (printable ? hello.peer_name() : std::string("?")) + "' from " +
                                        peer_address() + ": " + reason);
  Frame refused;
  refused.mutable_refused()->set_status(status);
  refused.mutable_refused()->set_reason(reason);
  close_link(std::move(refused), "refused: " + reason);
}

void ServerSession::refuse_credential(const char* why, Status status, const std::string& reason, const Hello& hello) {
  server_.authentication_failures.count(why);
  refuse(status, reason, hello);
}

void ServerSession::refuse_hello(Status status, const std::string& reason, const Hello& hello) {
  server_.protocol_errors.count("BAD_HELLO");
  refuse(status, reason, hello);
}

void ServerSession::handshake(Frame&& frame) {
  handshake_timer_.cancel();
  if (!frame.has_hello()) {
    protocol_violation("expected Hello as the first frame, got " + std::string(frame_body_name(frame)));
    return;
  }
  Hello& hello = *frame.mutable_hello();
  const ServerOptions& options = server_.options;
  if (hello.version() != kProtocolVersion) {
    refuse_hello(Status::INTERNAL,
                 "protocol version " + std::to_string(hello.version()) + " not supported, server speaks " +
                     std::to_string(kProtocolVersion),
                 hello);
    return;
  }
  if (auto why = peer_name_problem(hello.peer_name()); !why.empty()) {
    refuse_hello(Status::BAD_ARGUMENTS, "peer_name is not valid: " + why, hello);
    return;
  }
  // 0 (unset) asks for the least role, CLIENT; a number this version does not know is refused.
  if (hello.role() < Role::ROLE_UNSPECIFIED || hello.role() > Role::OPERATOR) {
    refuse_hello(Status::BAD_ARGUMENTS,
                 "Hello.role " + std::to_string(static_cast<int>(hello.role())) +
                     " is not a role of protocol version 1 (0 or CLIENT 1, SAM 2, OPERATOR 3)",
                 hello);
    return;
  }
  if (!hello.token().empty() && !token_transport_allowed(secure(), options.allow_plaintext_tokens, source_address_)) {
    refuse_credential(
        "plaintext_token", Status::UNAUTHENTICATED,
        "a token over plain TCP is accepted from loopback only: connect with TLS (--tls), or the operator "
        "starts the server with --allow-plaintext-tokens",
        hello);
    return;
  }
  Admission admission;
  if (auto authenticator = server_.current_authenticator()) {
    admission = authenticator->admit(hello.token(), certificate_name());
    if (!admission.ok()) {
      // What was presented says which check failed; the authenticator's reason is for the peer.
      const char* why = !hello.token().empty()        ? "wrong_token"
                        : !certificate_name().empty() ? "unknown_certificate"
                                                      : "token_required";
      refuse_credential(why, admission.status, admission.reason, hello);
      return;
    }
  } else {
    admission.name = kAnonymousIdentity;
    admission.role = Role::OPERATOR;
  }
  if (hello.role() > admission.role) {
    refuse_credential("role_not_granted", Status::PERMISSION_DENIED,
                      "credential '" + admission.name + "' has role " + role_word(admission.role) +
                          "; Hello asks for " + role_word(hello.role()) +
                          (hello.role() == Role::SAM ? " (to register services)" : ""),
                      hello);
    return;
  }
  // A session of the credential's fair share of the connections (max_sessions_per_credential;
  // client credentials leave the reserve to sam and operator sessions).
  const ShareHolder holder{admission.name, admission.role >= Role::SAM};
  if (auto refusal = server_.session_share->take(holder, 1); !refusal.empty()) {
    refuse(Status::RESOURCE_EXHAUSTED, "session not opened: " + refusal, hello);
    return;
  }
  holder_ = holder;
  set_budget(std::make_shared<ShareBudget>(server_.buffer_share, server_.buffer_share->account(holder)));
  const std::string secret = hello.session_secret();
  hello.clear_token();
  hello.clear_session_secret();
  hello_ = std::move(hello);
  auto opened = server_.directory.open(secret, holder, self());
  forgotten_session_ = opened.forgotten_session;
  forgotten_publish_through_ = opened.forgotten_publish_through;
  identity_.name = std::move(admission.name);
  identity_.role = admission.role;
  identity_.session = opened.session;
  identity_.fingerprint = std::move(admission.fingerprint);

  Frame welcome_frame;
  Welcome& welcome = *welcome_frame.mutable_welcome();
  welcome.set_version(kProtocolVersion);
  welcome.set_space(options.space);
  welcome.set_server_instance(server_.instance);
  welcome.set_heartbeat_interval_ms(static_cast<uint32_t>(options.heartbeat_interval.count()));
  welcome.set_heartbeat_timeout_ms(static_cast<uint32_t>(options.heartbeat_timeout.count()));
  welcome.set_max_message_bytes(options.max_message_bytes);
  welcome.set_chunk_bytes(options.chunk_bytes);
  welcome.set_session_secret(opened.secret);
  welcome.set_identity(identity_.name);
  welcome.set_role(identity_.role);
  enqueue(std::move(welcome_frame));

  opened_ = true;
  mark_open();
  set_limits(server_.session_limits(), options.chunk_bytes);  // Hello limits no more
  set_heartbeat(options.heartbeat_interval, options.heartbeat_timeout);
  spdlog::info("planet: {} open: {} (role {}), session {}{}", describe(), identity_.name, role_word(identity_.role),
               identity_.session,
               opened.resumed ? " resumed"
               : opened.forgotten_session
                   ? " (continues session " + std::to_string(opened.forgotten_session) + ", which was no longer kept)"
                   : std::string());
  if (opened.previous) {
    spdlog::info("planet: session {} resumed by connection {}; closing its previous connection", identity_.session,
                 id_);
    opened.previous->close(Status::UNAVAILABLE, "session resumed from another connection");
  }
  server_.handler.on_open(self());
}

}  // namespace urs::planet
