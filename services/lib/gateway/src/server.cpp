#include "urs/gateway/server.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>
#include <fstream>
#include <sstream>
#include <thread>

#include "urs/agent/agent.hpp"
#include "urs/gateway/json_writer.hpp"
#include "urs/gateway/protocol.hpp"
#include "urs/planet/authenticator.hpp"

namespace urs::gateway {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

namespace {

constexpr const char* kCookie = "urs_gateway";
constexpr std::size_t kMaxFile = 4u << 20;

// The value of cookie `name` in a Cookie header ("a=1; b=2"), "" if absent.
std::string cookie(const Request& request, const std::string& name) {
  const auto header = request.find(http::field::cookie);
  if (header == request.end()) return {};
  const std::string text(header->value());
  std::size_t at = 0;
  while (at < text.size()) {
    const auto end = std::min(text.find(';', at), text.size());
    std::string pair = text.substr(at, end - at);
    const auto first = pair.find_first_not_of(' ');
    pair = first == std::string::npos ? "" : pair.substr(first);
    const auto equals = pair.find('=');
    if (equals != std::string::npos && pair.substr(0, equals) == name) return pair.substr(equals + 1);
    at = end + 1;
  }
  return {};
}

// The value of query parameter `name` in a target ("/?session=ab"), "" if absent. Ids are hex:
// nothing to decode.
std::string query(const std::string& target, const std::string& name) {
  const auto mark = target.find('?');
  if (mark == std::string::npos) return {};
  std::stringstream parts(target.substr(mark + 1));
  std::string part;
  while (std::getline(parts, part, '&')) {
    if (part.rfind(name + "=", 0) == 0) return part.substr(name.size() + 1);
  }
  return {};
}

std::string path_of(const std::string& target) { return target.substr(0, target.find('?')); }

const char* content_type(const std::string& path) {
  const auto dot = path.rfind('.');
  const std::string extension = dot == std::string::npos ? "" : path.substr(dot + 1);
  if (extension == "html") return "text/html; charset=utf-8";
  if (extension == "js") return "text/javascript; charset=utf-8";
  if (extension == "css") return "text/css; charset=utf-8";
  if (extension == "svg") return "image/svg+xml";
  if (extension == "png") return "image/png";
  if (extension == "json") return "application/json";
  if (extension == "ico") return "image/x-icon";
  return "application/octet-stream";
}

// A path of the dashboard's files: letters, digits, '-', '_', '.', '/' and no "..".
bool safe_path(const std::string& path) {
  if (path.empty() || path.front() != '/' || path.size() > 200) return false;
  for (char c : path) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
                    c == '_' || c == '.' || c == '/';
    if (!ok) return false;
  }
  return path.find("..") == std::string::npos && path.find("//") == std::string::npos;
}

Response respond(const Request& request, http::status status, std::string body, const char* type) {
  Response response{status, request.version()};
  response.set(http::field::server, "urs-gateway");
  response.set(http::field::content_type, type);
  response.set(http::field::cache_control, "no-store");
  response.set("X-Content-Type-Options", "nosniff");
  response.set("X-Frame-Options", "DENY");
  response.set("Content-Security-Policy",
               "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:; style-src 'self'; "
               "frame-ancestors 'none'");
  response.keep_alive(request.keep_alive());
  response.body() = std::move(body);
  response.prepare_payload();
  return response;
}

Response json_response(const Request& request, http::status status, std::string json) {
  return respond(request, status, std::move(json), "application/json");
}

Response error_response(const Request& request, http::status status, const std::string& message) {
  JsonWriter out;
  out.begin_object().key("error").value(message).end_object();
  return json_response(request, status, out.take());
}

// What the CAMUS server said of a login's credential, when it was asked: "identity" (the
// credential's name) and "server_role" (client, sam or operator), so the dashboard can say why a
// login only sees.
void describe_credential(JsonWriter& out, const Login& login) {
  if (login.identity.empty()) return;
  out.key("identity").value(login.identity).key("server_role").value(planet::role_word(login.server_role));
}

}  // namespace

// ---- the WebSocket of one client ------------------------------------------------------------------

class WsSession : public Outbox, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Hub& hub, Role role, std::string login, std::size_t max_queue_bytes,
            std::atomic<std::size_t>& clients)
      : ws_(std::move(socket)), hub_(hub), role_(role), login_(std::move(login)), max_queue_bytes_(max_queue_bytes),
        clients_(clients) {
    ++clients_;
  }
  ~WsSession() override { --clients_; }

  void run(Request request) {
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& response) {
      response.set(http::field::server, "urs-gateway");
      response.set(http::field::sec_websocket_protocol, foxglove::kSubprotocol);
    }));
    ws_.read_message_max(foxglove::kMaxBinaryMessage);
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code error) { self->on_accept(error); });
  }

  // Outbox
  bool send_text(std::string text) override { return enqueue(Frame{std::move(text), nullptr, true}); }
  bool send_binary(std::string header, std::shared_ptr<const std::string> payload) override {
    return enqueue(Frame{std::move(header), std::move(payload), false});
  }

  // After the I/O thread has stopped: leaves the hub (nothing is sent any more) and closes.
  void detach() {
    finish();
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

 private:
  struct Frame {
    std::string head;
    std::shared_ptr<const std::string> payload;
    bool text = false;
    std::size_t size() const { return head.size() + (payload ? payload->size() : 0); }
  };

  void on_accept(beast::error_code error) {
    if (error) {
      spdlog::debug("gateway: WebSocket handshake failed: {}", error.message());
      return;
    }
    client_ = hub_.connect(shared_from_this(), role_, login_);
    connected_ = true;
    read();
  }

  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code error, std::size_t) {
      if (error) {
        self->finish();
        return;
      }
      const auto data = self->buffer_.data();
      const std::string_view bytes(static_cast<const char*>(data.data()), data.size());
      if (self->ws_.got_text()) {
        self->hub_.receive_text(self->client_, bytes);
      } else {
        self->hub_.receive_binary(self->client_, bytes);
      }
      self->buffer_.consume(self->buffer_.size());
      self->read();
    });
  }

  bool enqueue(Frame frame) {
    std::lock_guard lock(mutex_);
    if (dropping_ || closed_) return false;
    if (queued_bytes_ + frame.size() > max_queue_bytes_) {
      // Slower than what it subscribed to: dropped, and what waited for it freed at once.
      dropping_ = true;
      spdlog::warn("gateway: client {} is too slow ({} bytes waiting, at most {}); dropping it", client_.load(),
                   queued_bytes_, max_queue_bytes_);
      queue_.clear();
      queued_bytes_ = 0;
      net::post(ws_.get_executor(), [self = shared_from_this()] { self->drop(); });
      return false;
    }
    queued_bytes_ += frame.size();
    queue_.push_back(std::move(frame));
    if (!writing_) {
      writing_ = true;
      net::post(ws_.get_executor(), [self = shared_from_this()] { self->write_next(); });
    }
    return true;
  }

  // On the I/O thread: one write at a time, in order.
  void write_next() {
    {
      std::lock_guard lock(mutex_);
      if (closed_ || dropping_ || queue_.empty()) {
        writing_ = false;
        return;
      }
      current_ = std::move(queue_.front());
      queue_.pop_front();
    }
    in_flight_ = true;
    ws_.text(current_.text);
    std::array<net::const_buffer, 2> buffers{
        net::buffer(current_.head),
        current_.payload ? net::buffer(*current_.payload) : net::const_buffer()};
    ws_.async_write(buffers, [self = shared_from_this()](beast::error_code error, std::size_t) {
      self->in_flight_ = false;
      {
        std::lock_guard lock(self->mutex_);
        const std::size_t size = self->current_.size();
        self->queued_bytes_ = self->queued_bytes_ >= size ? self->queued_bytes_ - size : 0;
        self->current_ = Frame{};
        if (error) {
          self->closed_ = true;
          self->writing_ = false;
          return;  // the read side sees the failure and finishes
        }
      }
      self->write_next();
    });
  }

  // On the I/O thread, once the client is too slow: out of the hub at once, then a close (1008,
  // policy violation), bounded; a peer that does not even take the write in flight has its
  // connection cut instead (a close frame could not reach it).
  void drop() {
    leave_hub();
    beast::error_code ignored;
    if (in_flight_) {
      beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
      beast::get_lowest_layer(ws_).socket().close(ignored);
      return;
    }
    ws_.set_option(websocket::stream_base::timeout{std::chrono::seconds(5), std::chrono::seconds(5), false});
    ws_.async_close(websocket::close_reason(websocket::close_code::policy_error, "too slow: dropped"),
                    [self = shared_from_this()](beast::error_code) { self->finish(); });
  }

  void finish() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
      queue_.clear();
      queued_bytes_ = 0;
    }
    leave_hub();
  }

  void leave_hub() {
    if (connected_) {
      connected_ = false;
      hub_.disconnect(client_);
    }
  }

  websocket::stream<beast::tcp_stream> ws_;
  Hub& hub_;
  const Role role_;
  const std::string login_;
  const std::size_t max_queue_bytes_;
  std::atomic<std::size_t>& clients_;
  beast::flat_buffer buffer_;
  std::atomic<uint64_t> client_{0};  // set on the I/O thread, named in other threads' warnings
  bool connected_ = false;  // I/O thread's own
  bool in_flight_ = false;  // I/O thread's own: a write is under way

  std::mutex mutex_;  // guards the queue and the flags below
  std::deque<Frame> queue_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool dropping_ = false;
  bool closed_ = false;
  Frame current_;  // being written (I/O thread)
};

// ---- the server ------------------------------------------------------------------------------------

// Members in this order: the I/O context goes first when destroyed (with the handlers it still
// holds, and the sessions they keep), while the counters those sessions update still exist.
struct Server::Impl {
  Impl(ServerOptions options, Hub& hub, Logins& logins)
      : options(std::move(options)), hub(hub), logins(logins), acceptor(ioc) {}

  const ServerOptions options;
  Hub& hub;
  Logins& logins;
  agent::WorkerPool login_pool{1};
  std::atomic<std::size_t> connections{0};
  std::atomic<std::size_t> clients{0};
  std::mutex sessions_mutex;
  std::vector<std::weak_ptr<WsSession>> sessions;
  bool stopped = false;
  std::thread thread;
  net::io_context ioc{1};
  tcp::acceptor acceptor;

  void accept();
};

namespace {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server::Impl* server) : stream_(std::move(socket)), server_(server) {
    ++server_->connections;
  }
  ~HttpSession() { --server_->connections; }

  void read() {
    parser_.emplace();
    parser_->header_limit(8 * 1024);
    parser_->body_limit(4 * 1024);
    stream_.expires_after(server_->options.http_timeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code error, std::size_t) { self->on_read(error); });
  }

 private:
  void on_read(beast::error_code error) {
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

  void send(Response response) {
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

  // The login of a request: its cookie's or its ?session= (a Foxglove URL's).
  std::shared_ptr<const Login> login_of(const Request& request, bool& by_cookie) {
    std::string id = cookie(request, kCookie);
    by_cookie = !id.empty();
    if (id.empty()) id = query(std::string(request.target()), "session");
    if (id.empty() || id.size() > 64) return nullptr;
    return server_->logins.find(id);
  }

  void upgrade(Request request) {
    const Server::Impl& server = *server_;
    if (path_of(std::string(request.target())) != "/") {
      send(error_response(request, http::status::not_found, "the WebSocket endpoint is ws://HOST:PORT/"));
      return;
    }
    const auto protocols = request.find(http::field::sec_websocket_protocol);
    if (protocols == request.end() ||
        std::string(protocols->value()).find(foxglove::kSubprotocol) == std::string::npos) {
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
    std::string login_id;
    if (login) {
      role = login->role;
      login_id = login->id;
    } else if (server.options.anonymous) {
      role = *server.options.anonymous;
    } else {
      send(error_response(request, http::status::unauthorized,
                          "log in first (POST /api/login, or ?session=<id> from the dashboard)"));
      return;
    }
    if (server.clients >= server.options.max_clients) {
      send(error_response(request, http::status::service_unavailable,
                          "too many WebSocket clients (" + std::to_string(server.options.max_clients) + ")"));
      return;
    }
    auto session = std::make_shared<WsSession>(stream_.release_socket(), server_->hub, role, login_id,
                                               server.options.max_queue_bytes, server_->clients);
    {
      std::lock_guard lock(server_->sessions_mutex);
      auto& sessions = server_->sessions;
      sessions.erase(std::remove_if(sessions.begin(), sessions.end(), [](auto& s) { return s.expired(); }),
                     sessions.end());
      sessions.push_back(session);
    }
    session->run(std::move(request));
  }

  void handle(Request request) {
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

  void login(Request request) {
    google::protobuf::Value body;
    std::string credential;
    if (google::protobuf::util::JsonStringToMessage(request.body(), &body).ok() &&
        body.kind_case() == google::protobuf::Value::kStructValue) {
      const auto& fields = body.struct_value().fields();
      const auto it = fields.find("credential");
      if (it != fields.end() && it->second.kind_case() == google::protobuf::Value::kStringValue) {
        credential = it->second.string_value();
      }
    }
    if (credential.empty()) {
      send(error_response(request, http::status::bad_request, "send {\"credential\": \"...\"}"));
      return;
    }
    // Verifying may take a round trip to the CAMUS server: off the I/O thread.
    server_->login_pool.post([self = shared_from_this(), request = std::move(request),
                              credential = std::move(credential)](bool cancelled) mutable {
      LoginResult result = cancelled ? LoginResult{nullptr, 503, "the gateway is stopping"}
                                     : self->server_->logins.login(credential);
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
        response.set(http::field::set_cookie, std::string(kCookie) + "=" + result.login->id +
                                                  "; HttpOnly; SameSite=Strict; Path=/");
        self->send(std::move(response));
      });
    });
  }

  void logout(const Request& request) {
    const std::string id = cookie(request, kCookie);
    if (!id.empty()) server_->logins.logout(id);
    Response response = json_response(request, http::status::ok, "{}");
    response.set(http::field::set_cookie, std::string(kCookie) + "=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0");
    send(std::move(response));
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_{16 * 1024};
  std::optional<http::request_parser<http::string_body>> parser_;
  Server::Impl* server_;
};

}  // namespace

void Server::Impl::accept() {
  acceptor.async_accept(ioc, [self = this](beast::error_code error, tcp::socket socket) {
    if (error) {
      if (error != net::error::operation_aborted) spdlog::warn("gateway: accept: {}", error.message());
      if (!self->acceptor.is_open()) return;
    } else if (self->connections >= self->options.max_connections) {
      beast::error_code ignored;
      socket.close(ignored);  // at the limit: refused at once
    } else {
      std::make_shared<HttpSession>(std::move(socket), self)->read();
    }
    self->accept();
  });
}

Server::Server(ServerOptions options, Hub& hub, Logins& logins)
    : impl_(std::make_unique<Impl>(std::move(options), hub, logins)) {
  Impl& d = *impl_;
  beast::error_code error;
  const auto address = net::ip::make_address(d.options.host, error);
  if (error) throw std::runtime_error("--listen: '" + d.options.host + "' is not an IP address");
  const tcp::endpoint endpoint(address, d.options.port);
  d.acceptor.open(endpoint.protocol(), error);
  if (!error) d.acceptor.set_option(net::socket_base::reuse_address(true), error);
  if (!error) d.acceptor.bind(endpoint, error);
  if (!error) d.acceptor.listen(net::socket_base::max_listen_connections, error);
  if (error) {
    throw std::runtime_error("cannot listen on " + d.options.host + ":" + std::to_string(d.options.port) + ": " +
                             error.message());
  }
}

Server::~Server() { stop(); }

uint16_t Server::port() const { return impl_->acceptor.local_endpoint().port(); }

void Server::start() {
  impl_->accept();
  impl_->thread = std::thread([impl = impl_.get()] { impl->ioc.run(); });
}

void Server::stop() {
  Impl& d = *impl_;
  if (d.stopped) return;
  d.stopped = true;
  d.login_pool.stop();  // a login still running answers "stopping" into the I/O context
  d.ioc.stop();
  if (d.thread.joinable()) d.thread.join();
  beast::error_code ignored;
  d.acceptor.close(ignored);
  // The I/O thread is gone: each client leaves the hub here (the hub would otherwise keep its
  // session, and so its socket, past the I/O context).
  std::lock_guard lock(d.sessions_mutex);
  for (auto& weak : d.sessions) {
    if (auto session = weak.lock()) session->detach();
  }
  d.sessions.clear();
}

}  // namespace urs::gateway
