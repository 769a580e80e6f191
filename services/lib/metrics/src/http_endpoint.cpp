#include "urs/metrics/http_endpoint.hpp"

#include <spdlog/spdlog.h>

#include <asio.hpp>
#include <atomic>
#include <thread>

namespace urs::metrics {
namespace {

constexpr size_t kMaxHeadBytes = 8192;
constexpr std::chrono::seconds kReadTimeout{5};
constexpr size_t kMaxConnections = 16;

struct Response {
  int status = 200;
  const char* reason = "OK";
  const char* content_type = "text/plain; charset=utf-8";
  std::string body;
  std::string extra_headers;
};

}  // namespace

// Handlers capture `this`: the io_context (a member) is stopped, and its handlers destroyed, before
// the rest of Impl goes.
struct HttpEndpoint::Impl {
  explicit Impl(Metrics& metrics_in) : metrics(metrics_in), acceptor(io) {}

  Metrics& metrics;
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor;
  std::atomic<size_t> connections{0};
  std::thread thread;

  void accept() {
    acceptor.async_accept([self = this](const std::error_code& error, asio::ip::tcp::socket socket) {
      if (error == asio::error::operation_aborted || !self->acceptor.is_open()) return;
      if (!error) self->serve(std::move(socket));
      self->accept();
    });
  }

  // One connection: read the request head (bounded in size and time), answer, close.
  void serve(asio::ip::tcp::socket socket) {
    if (connections.load() >= kMaxConnections) {
      std::error_code ignored;
      socket.close(ignored);
      return;
    }
    ++connections;
    struct Connection {
      explicit Connection(asio::ip::tcp::socket s, asio::io_context& io)
          : socket(std::move(s)), buffer(kMaxHeadBytes), timer(io) {}
      asio::ip::tcp::socket socket;
      asio::streambuf buffer;
      asio::steady_timer timer;
      std::string out;
    };
    auto connection = std::make_shared<Connection>(std::move(socket), io);
    connection->timer.expires_after(kReadTimeout);
    connection->timer.async_wait([connection](const std::error_code& error) {
      if (error) return;
      std::error_code ignored;
      connection->socket.close(ignored);
    });
    asio::async_read_until(connection->socket, connection->buffer, "\r\n\r\n",
                           [self = this, connection](const std::error_code& error, size_t) {
                             connection->timer.cancel();
                             if (error) {  // closed, timed out, or a head over kMaxHeadBytes
                               if (error == asio::error::not_found) {
                                 connection->out =
                                     "HTTP/1.1 431 Request Header Fields Too Large\r\nContent-Length: 0\r\n"
                                     "Connection: close\r\n\r\n";
                                 self->write(connection);
                               } else {
                                 --self->connections;
                               }
                               return;
                             }
                             std::istream in(&connection->buffer);
                             std::string line;
                             std::getline(in, line);
                             connection->out = self->answer(line);
                             self->write(connection);
                           });
  }

  template <typename Connection>
  void write(const std::shared_ptr<Connection>& connection) {
    asio::async_write(connection->socket, asio::buffer(connection->out),
                      [self = this, connection](const std::error_code&, size_t) {
                        std::error_code ignored;
                        connection->socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
                        connection->socket.close(ignored);
                        --self->connections;
                      });
  }

  // The whole response to the request line `line` ("GET /metrics HTTP/1.1\r").
  std::string answer(std::string line) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find(' ');
    const auto second = first == std::string::npos ? std::string::npos : line.find(' ', first + 1);
    Response response;
    if (second == std::string::npos || line.compare(second + 1, 5, "HTTP/") != 0) {
      response = {400, "Bad Request", "text/plain; charset=utf-8", "not an HTTP/1.x request line\n", {}};
      return render(response, false);
    }
    const std::string method = line.substr(0, first);
    std::string path = line.substr(first + 1, second - first - 1);
    path = path.substr(0, path.find('?'));
    const bool head = method == "HEAD";
    if (method != "GET" && !head) {
      response = {405, "Method Not Allowed", "text/plain; charset=utf-8", "only GET and HEAD\n",
                  "Allow: GET, HEAD\r\n"};
    } else if (path == "/metrics") {
      response.content_type = "text/plain; version=0.0.4; charset=utf-8";
      try {
        response.body = metrics.scrape();
      } catch (const std::exception& e) {
        spdlog::error("metrics: /metrics not collected: {}", e.what());
        response = {500, "Internal Server Error", "text/plain; charset=utf-8", "metrics not collected\n", {}};
      }
    } else if (path == "/healthz") {
      response.body = "ok\n";
    } else if (path == "/readyz") {
      auto report = metrics.health().readiness();
      response.body = report.text;
      if (!report.ready) {
        response.status = 503;
        response.reason = "Service Unavailable";
      }
    } else {
      response = {404, "Not Found", "text/plain; charset=utf-8", "/metrics, /healthz or /readyz\n", {}};
    }
    return render(response, head);
  }

  static std::string render(const Response& response, bool head) {
    std::string out = "HTTP/1.1 " + std::to_string(response.status) + " " + response.reason + "\r\n";
    out += "Content-Type: " + std::string(response.content_type) + "\r\n";
    out += "Content-Length: " + std::to_string(response.body.size()) + "\r\n";
    out += response.extra_headers;
    out += "Connection: close\r\n\r\n";
    if (!head) out += response.body;
    return out;
  }
};

HttpEndpoint::HttpEndpoint(const util::Endpoint& listen, Metrics& metrics) : impl_(std::make_unique<Impl>(metrics)) {
  try {
    asio::ip::tcp::resolver resolver(impl_->io);
    auto results = resolver.resolve(listen.host, std::to_string(listen.port),
                                    asio::ip::tcp::resolver::passive | asio::ip::tcp::resolver::numeric_service);
    if (results.empty()) throw std::runtime_error("no address");
    const auto endpoint = results.begin()->endpoint();
    impl_->acceptor.open(endpoint.protocol());
    impl_->acceptor.set_option(asio::ip::tcp::acceptor::reuse_address(true));
    impl_->acceptor.bind(endpoint);
    impl_->acceptor.listen();
  } catch (const std::exception& e) {
    throw util::ConfigError("--metrics-listen: cannot listen on " + listen.str() + ": " + e.what() +
                            " (is another process using the port? choose another)");
  }
  impl_->accept();
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
  spdlog::info("metrics: serving /metrics, /healthz and /readyz on {}:{}", listen.host, port());
}

HttpEndpoint::~HttpEndpoint() {
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

uint16_t HttpEndpoint::port() const { return impl_->acceptor.local_endpoint().port(); }

}  // namespace urs::metrics
