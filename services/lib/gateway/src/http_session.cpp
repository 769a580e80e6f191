#include "http_session.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <boost/asio/post.hpp>
#include <boost/beast/websocket.hpp>
#include <fstream>

#include "server_impl.hpp"
#include "urs/gateway/json_writer.hpp"
#include "urs/gateway/protocol.hpp"
#include "urs/planet/authenticator.hpp"
#include "ws_session.hpp"

namespace urs::gateway {

namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using http_util::content_type;
using http_util::cookie;
using http_util::error_response;
using http_util::json_response;
using http_util::path_of;
using http_util::query;
using http_util::respond;
using http_util::safe_path;

namespace {

constexpr const char* kCookie = "urs_gateway";
constexpr const char* kLogInFirst =
    "log in first: POST /api/login {\"credential\": ...} gives a session; connect to ws://HOST:PORT/?session=<id>";
constexpr std::size_t kMaxFile = 4u << 20;

// What the CAMUS server said of a login's credential, when it was asked: "identity" (the
// credential's name) and "server_role" (client, sam or operator), so the dashboard can say why a
// login only sees.
void describe_credential(JsonWriter& out, const Login& login) {
  if (login.identity.empty()) return;
  out.key("identity").value(login.identity).key("server_role").value(planet::role_word(login.server_role));
}

// The string member `name` of a JSON object body, "" if there is none.
std::string body_string(const Request& request, const std::string& name) {
  google::protobuf::Value body;
  if (!google::protobuf::util::JsonStringToMessage(request.body(), &body).ok() ||
      body.kind_case() != google::protobuf::Value::kStructValue) {
    return {};
  }
  const auto& fields = body.struct_value().fields();
  const auto it = fields.find(name);
  return it != fields.end() && it->second.kind_case() == google::protobuf::Value::kStringValue
             ? it->second.string_value()
             : std::string();
}

}  // namespace

HttpSession::HttpSession(tcp::socket&& socket, Server::Impl* server) : stream_(std::move(socket)), server_(server) {
  ++server_->connections;
}
HttpSession::~HttpSession() { --server_->connections; }

void HttpSession::read() {
  parser_.emplace();
  parser_->header_limit(8 * 1024);
  parser_->body_limit(4 * 1024);
  stream_.expires_after(server_->options.http_timeout);
  http::async_read(stream_, buffer_, *parser_,
                   [self = shared_from_this()](beast::error_code error, std::size_t) { self->on_read(error); });
}

void HttpSession::on_read(beast::error_code error) {
  if (error == http::error::end_of_stream || error) {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    return;
  }
  Request request = parser_->release();
  if (websocket::is_upgrade(request)) {
    upgrade(std::move(request));
    return;
  }
  handle(std::move(request));
}

void HttpSession::send(Response response) {
  auto shared = std::make_shared<Response>(std::move(response));
  http::async_write(stream_, *shared, [self = shared_from_this(), shared](beast::error_code error, std::size_t) {
    if (error || !shared->keep_alive()) {
      beast::error_code ignored;
      self->stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
      return;
    }
    self->read();
  });
}

std::shared_ptr<const Login> HttpSession::login_of(const Request& request, bool& by_cookie) {
  std::string id = cookie(request, kCookie);
  by_cookie = !id.empty();
  if (id.empty()) id = query(std::string(request.target()), "session");
  if (id.empty() || id.size() > 64) return nullptr;
  return server_->logins.find(id);
}

void HttpSession::upgrade(Request request) {
  const Server::Impl& server = *server_;
  if (path_of(std::string(request.target())) != "/") {
    send(error_response(request, http::status::not_found, "the WebSocket endpoint is ws://HOST:PORT/"));
    return;
  }
  const auto protocols = request.find(http::field::sec_websocket_protocol);
  if (protocols == request.end() || std::string(protocols->value()).find(foxglove::kSubprotocol) == std::string::npos) {
    send(error_response(request, http::status::bad_request,
                        std::string("subprotocol ") + foxglove::kSubprotocol + " required"));
    return;
  }
  bool by_cookie = false;
  std::shared_ptr<const Login> login = login_of(request, by_cookie);
  // A cookie travels with any page's request: only this server's own pages may use it.
  if (login && by_cookie) {
    const auto origin = request.find(http::field::origin);
    const auto host = request.find(http::field::host);
    if (origin != request.end() && host != request.end()) {
      const std::string from(origin->value());
      const std::string expected_http = "http://" + std::string(host->value());
      const std::string expected_https = "https://" + std::string(host->value());
      if (from != expected_http && from != expected_https) {
        send(error_response(request, http::status::forbidden, "origin " + from + " may not use this login"));
        return;
      }
    }
  }
  Role role;
  std::string login_id, identity;
  std::string refusal;
  if (login) {
    role = login->role;
    login_id = login->id;
    identity = login->identity;
  } else if (server.options.anonymous) {
    role = *server.options.anonymous;
  } else {
    refusal = kLogInFirst;
    if (request.find(http::field::origin) == request.end()) {
      // A program (curl, a WebSocket library) reads the refusal's body.
      send(error_response(request, http::status::unauthorized, refusal));
      return;
    }
    // A browser page cannot read a refused upgrade's body: it gets the WebSocket, a Status and a
    // close frame saying the same, and nothing else.
  }
  if (server.clients >= server.options.max_clients) {
    send(error_response(request, http::status::service_unavailable,
                        "too many WebSocket clients (" + std::to_string(server.options.max_clients) + ")"));
    return;
  }
  auto session = std::make_shared<WsSession>(stream_.release_socket(), server_->hub, role, login_id, identity,
                                             server.options.max_queue_bytes, server_->clients, std::move(refusal));
  server_->add_session(session);
  session->run(std::move(request));
}

void HttpSession::handle(Request request) {
  const std::string target(request.target());
  const std::string path = path_of(target);
  if (path == "/api/login" || path == "/api/logout") {
    if (request.method() != http::verb::post) {
      send(error_response(request, http::status::method_not_allowed, path + " takes POST"));
      return;
    }
    // Only a page's script can send JSON here (another site's form cannot, without asking first).
    const auto type = request.find(http::field::content_type);
    if (type == request.end() || std::string(type->value()).rfind("application/json", 0) != 0) {
      send(error_response(request, http::status::unsupported_media_type, "send application/json"));
      return;
    }
    if (path == "/api/login") {
      login(std::move(request));
    } else {
      logout(request);
    }
    return;
  }
  if (request.method() != http::verb::get && request.method() != http::verb::head) {
    send(error_response(request, http::status::method_not_allowed, "GET only"));
    return;
  }
  if (path == "/api/whoami") {
    bool by_cookie = false;
    auto login = login_of(request, by_cookie);
    const auto& anonymous = server_->options.anonymous;
    JsonWriter out;
    out.begin_object().key("space").value(server_->options.space);
    out.key("role");
    if (login) {
      out.value(role_name(login->role));
      describe_credential(out, *login);
    } else if (anonymous) {
      out.value(role_name(*anonymous));
    } else {
      out.null();
    }
    out.key("login").value(login != nullptr);
    out.key("anonymous");
    if (anonymous) {
      out.value(role_name(*anonymous));
    } else {
      out.null();
    }
    send(json_response(request, http::status::ok, out.end_object().take()));
    return;
  }
  const std::string file = path == "/" ? "/index.html" : path;
  if (!safe_path(file)) {
    send(error_response(request, http::status::not_found, "no such file"));
    return;
  }
  std::ifstream in(server_->options.web_dir + file, std::ios::binary);
  if (!in) {
    send(error_response(request, http::status::not_found, "no such file: " + file));
    return;
  }
  std::string body;
  char chunk[16384];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
    body.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (body.size() > kMaxFile) {
      send(error_response(request, http::status::internal_server_error, "file too large"));
      return;
    }
  }
  Response response = respond(request, http::status::ok, std::move(body), content_type(file));
  if (request.method() == http::verb::head) response.body().clear();
  send(std::move(response));
}

void HttpSession::login(Request request) {
  std::string credential = body_string(request, "credential");
  if (credential.empty()) {
    send(error_response(request, http::status::bad_request, "send {\"credential\": \"...\"}"));
    return;
  }
  // Verifying may take a round trip to the CAMUS server: off the I/O thread.
  server_->login_pool.post([self = shared_from_this(), request = std::move(request),
                            credential = std::move(credential)](bool cancelled) mutable {
    LoginResult result =
        cancelled ? LoginResult{nullptr, 503, "the gateway is stopping"} : self->server_->logins.login(credential);
    net::post(self->stream_.get_executor(), [self, request = std::move(request), result = std::move(result)] {
      if (!result.login) {
        self->send(error_response(request, static_cast<http::status>(result.http_status), result.error));
        return;
      }
      JsonWriter out;
      out.begin_object().key("role").value(role_name(result.login->role));
      describe_credential(out, *result.login);
      out.key("session").value(result.login->id).key("space").value(self->server_->options.space);
      Response response = json_response(request, http::status::ok, out.end_object().take());
      response.set(http::field::set_cookie,
                   std::string(kCookie) + "=" + result.login->id + "; HttpOnly; SameSite=Strict; Path=/");
      self->send(std::move(response));
    });
  });
}

// The session is the cookie's, else the body's {"session": "<id>"}, else ?session=<id>: as the
// login returned it, to a browser or to a program.
void HttpSession::logout(const Request& request) {
  std::string id = cookie(request, kCookie);
  if (id.empty()) id = body_string(request, "session");
  if (id.empty()) id = query(std::string(request.target()), "session");
  if (id.empty() || id.size() > 64) {
    send(error_response(request, http::status::bad_request,
                        "name the session: the login's cookie, {\"session\": \"<id>\"} or ?session=<id>"));
    return;
  }
  const bool ended = server_->logins.logout(id);
  // Its connections end too, saying why (a Foxglove connection would otherwise keep streaming).
  const std::size_t connections = ended ? server_->end_sessions(id, "logged out: log in again for a new session") : 0;
  JsonWriter out;
  out.begin_object().key("ended").value(ended).key("connections").value(static_cast<uint64_t>(connections));
  Response response = json_response(request, http::status::ok, out.end_object().take());
  response.set(http::field::set_cookie, std::string(kCookie) + "=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0");
  send(std::move(response));
}

}  // namespace urs::gateway
