#include "urs/gateway/server.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <stdexcept>

#include "http_session.hpp"
#include "server_impl.hpp"
#include "ws_session.hpp"

namespace urs::gateway {

namespace beast = boost::beast;
namespace net = boost::asio;
using tcp = net::ip::tcp;

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

void Server::Impl::add_session(const std::shared_ptr<WsSession>& session) {
  std::lock_guard lock(sessions_mutex);
  sessions.erase(std::remove_if(sessions.begin(), sessions.end(), [](auto& s) { return s.expired(); }), sessions.end());
  sessions.push_back(session);
}

std::size_t Server::Impl::end_sessions(const std::string& id, const std::string& reason) {
  if (id.empty()) return 0;
  std::vector<std::shared_ptr<WsSession>> ending;
  {
    std::lock_guard lock(sessions_mutex);
    for (auto& weak : sessions) {
      if (auto session = weak.lock(); session && session->login() == id) ending.push_back(std::move(session));
    }
  }
  for (auto& session : ending) session->end(reason);
  return ending.size();
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
