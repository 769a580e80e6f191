#pragma once
// One HTTP connection of the gateway: reads requests one after the other and answers them
// (server.hpp lists the routes): the dashboard's files, login, logout and whoami, or hands the
// connection over to a WsSession on a WebSocket upgrade at "/" once the upgrade is admitted (the
// subprotocol, a login by cookie from this server's own origin or by ?session=, else the
// anonymous role; at most max_clients WebSocket clients).
//
// Limits (hostile peers): request headers 8 KiB, bodies 4 KiB, each request within the server's
// HTTP timeout; files of at most 4 MiB, named by safe paths only (http_util::safe_path).
//
// Threads: everything runs on the server's one I/O thread, but the verification of a login,
// which may take a round trip to the CAMUS server: it runs on the server's login worker and its
// answer is posted back to the I/O thread.
// Ownership: shared; the I/O handlers in flight (and a login being verified) hold it. The server
// outlives it (its I/O context is stopped and destroyed first); it counts itself in the server's
// `connections`.

#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <memory>
#include <optional>
#include <string>

#include "http_util.hpp"
#include "urs/gateway/logins.hpp"
#include "urs/gateway/server.hpp"

namespace urs::gateway {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(boost::asio::ip::tcp::socket&& socket, Server::Impl* server);
  ~HttpSession();

  // Reads the next request (the first one, or the next after a kept-alive answer).
  void read();

 private:
  void on_read(beast::error_code error);
  void send(Response response);
  // The login of a request: its cookie's or its ?session= (a Foxglove URL's).
  std::shared_ptr<const Login> login_of(const Request& request, bool& by_cookie);
  void upgrade(Request request);
  void handle(Request request);
  void login(Request request);
  void logout(const Request& request);

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_{16 * 1024};
  std::optional<http::request_parser<http::string_body>> parser_;
  Server::Impl* server_;
};

}  // namespace urs::gateway
