// urs::gateway's network side with real sockets and real Fast DDS, in one process: the HTTP and
// WebSocket server (limits, logins, a slow client dropped while a fast one keeps receiving), and
// the DDS source reading another space's bridge on a real domain.
#include "urs/gateway/server.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "Diagnostic.pb.h"
#include "dds_domain.hpp"
#include "process.hpp"
#include "urs/federation/dds_link.hpp"
#include "urs/federation/state_link.hpp"
#include "urs/gateway/dds_source.hpp"
#include "urs/gateway/gateway.hpp"
#include "urs/gateway/hub.hpp"
#include "urs/gateway/logins.hpp"
#include "urs/gateway/protocol.hpp"
#include "urs/schema/schema.hpp"

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
namespace gw = urs::gateway;
using urs::test::wait_until;
using namespace std::chrono_literals;

namespace {

// A running server on 127.0.0.1 with a dashboard folder holding index.html.
class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = urs::test::make_temp_dir("gateway-server");
    std::ofstream(dir_ + "/index.html") << "<!doctype html><title>dashboard</title>";
    std::ofstream(dir_ + "/../outside.txt") << "must not be served";
  }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove(dir_ + "/../outside.txt");
    std::filesystem::remove_all(dir_);
  }
  void start(gw::ServerOptions options) {
    options.web_dir = dir_;
    options.space = "lab";
    server_ = std::make_unique<gw::Server>(options, hub_, logins_);
    server_->start();
  }
  std::string port() const { return std::to_string(server_->port()); }

  // One HTTP request on a connection of its own; the response (status -1 if the server closed it).
  http::response<http::string_body> request(http::verb verb, const std::string& target, const std::string& body = {},
                                            const std::string& type = {}) {
    net::io_context ioc;
    tcp::socket socket(ioc);
    socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), server_->port()));
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1:" + port());
    if (!type.empty()) req.set(http::field::content_type, type);
    req.body() = body;
    req.prepare_payload();
    http::write(socket, req);
    beast::flat_buffer buffer;
    http::response<http::string_body> response;
    beast::error_code error;
    http::read(socket, buffer, response, error);
    if (error) response.result(static_cast<unsigned>(599));
    return response;
  }

  std::string dir_;
  gw::Hub hub_{gw::HubOptions{}};
  gw::Logins logins_{[] {
    gw::LoginOptions o;
    o.space_token = "the-space-token";
    return o;
  }()};
  std::unique_ptr<gw::Server> server_;
};

// A WebSocket client with the Foxglove subprotocol; read() takes one message.
struct WsClient {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  beast::flat_buffer buffer;

  // `origin`: the Origin header a browser page sends (none: a program's connection).
  void connect(const std::string& port, const std::string& target = "/", int receive_buffer = 0,
               const std::string& origin = {}) {
    if (receive_buffer > 0) {
      ws.next_layer().open(tcp::v4());
      ws.next_layer().set_option(net::socket_base::receive_buffer_size(receive_buffer));
    }
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), static_cast<uint16_t>(std::stoi(port))));
    ws.set_option(websocket::stream_base::decorator([origin](websocket::request_type& req) {
      req.set(http::field::sec_websocket_protocol, gw::foxglove::kSubprotocol);
      if (!origin.empty()) req.set(http::field::origin, origin);
    }));
    ws.handshake("127.0.0.1:" + port, target);
  }
  std::string read() {
    buffer.consume(buffer.size());
    ws.read(buffer);
    return beast::buffers_to_string(buffer.data());
  }
  // Reads until a text message holding `needle`; returns it.
  std::string read_until(const std::string& needle) {
    for (int i = 0; i < 1000; ++i) {
      std::string message = read();
      if (ws.got_text() && message.find(needle) != std::string::npos) return message;
    }
    return {};
  }
};

}  // namespace

TEST_F(ServerTest, ServesTheDashboardAndNothingElse) {
  start({});
  auto index = request(http::verb::get, "/");
  EXPECT_EQ(index.result_int(), 200);
  EXPECT_NE(index.body().find("dashboard"), std::string::npos);
  EXPECT_EQ(index[http::field::content_type], "text/html; charset=utf-8");
  EXPECT_NE(std::string(index["Content-Security-Policy"]).find("default-src 'self'"), std::string::npos);
  EXPECT_EQ(request(http::verb::get, "/../outside.txt").result_int(), 404);
  EXPECT_EQ(request(http::verb::get, "/%2e%2e/outside.txt").result_int(), 404);
  EXPECT_EQ(request(http::verb::get, "/nothing.js").result_int(), 404);
  EXPECT_EQ(request(http::verb::delete_, "/").result_int(), 405);
  // A login must be JSON (another site's form cannot post it), and the credential right.
  EXPECT_EQ(request(http::verb::post, "/api/login", "credential=x", "application/x-www-form-urlencoded").result_int(),
            415);
  EXPECT_EQ(request(http::verb::post, "/api/login", "{\"credential\":\"wrong\"}", "application/json").result_int(),
            401);
  EXPECT_EQ(request(http::verb::post, "/api/login", std::string(8000, 'x'), "application/json").result_int(), 599)
      << "a body over 4 KiB is not read";
  auto login = request(http::verb::post, "/api/login", "{\"credential\":\"the-space-token\"}", "application/json");
  ASSERT_EQ(login.result_int(), 200) << login.body();
  EXPECT_NE(login.body().find("\"role\":\"operator\""), std::string::npos);
  const std::string cookie(login[http::field::set_cookie]);
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(cookie.find("SameSite=Strict"), std::string::npos);
  // Headers over the limit end the connection; the server keeps serving.
  EXPECT_EQ(request(http::verb::get, "/" + std::string(20000, 'a')).result_int(), 599);
  EXPECT_EQ(request(http::verb::get, "/").result_int(), 200);
}

TEST_F(ServerTest, WebSocketsNeedALoginUnlessAnonymousViewersAreAllowed) {
  start({});
  WsClient anonymous;
  EXPECT_THROW(anonymous.connect(port()), beast::system_error);
  auto login = request(http::verb::post, "/api/login", "{\"credential\":\"the-space-token\"}", "application/json");
  const std::string body = login.body();
  const auto at = body.find("\"session\":\"") + 11;
  const std::string session = body.substr(at, 32);
  WsClient logged;
  logged.connect(port(), "/?session=" + session);
  EXPECT_NE(logged.read().find("\"role\":\"operator\""), std::string::npos) << "serverInfo names the role";
  WsClient wrong;
  EXPECT_THROW(wrong.connect(port(), "/?session=00000000000000000000000000000000"), beast::system_error);
}

TEST_F(ServerTest, AnUnauthenticatedUpgradeIsToldHowToLogIn) {
  start({});
  // A program reads the refusal's body.
  {
    net::io_context ioc;
    tcp::socket socket(ioc);
    socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), server_->port()));
    http::request<http::string_body> req{http::verb::get, "/", 11};
    req.set(http::field::host, "127.0.0.1:" + port());
    req.set(http::field::connection, "Upgrade");
    req.set(http::field::upgrade, "websocket");
    req.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
    req.set(http::field::sec_websocket_version, "13");
    req.set(http::field::sec_websocket_protocol, gw::foxglove::kSubprotocol);
    http::write(socket, req);
    beast::flat_buffer buffer;
    http::response<http::string_body> response;
    http::read(socket, buffer, response);
    EXPECT_EQ(response.result_int(), 401);
    EXPECT_NE(response.body().find("log in first: POST /api/login"), std::string::npos) << response.body();
  }
  // A browser page cannot read it: it gets the WebSocket, a Status and a close frame saying the same.
  WsClient browser;
  browser.connect(port(), "/", 0, "http://elsewhere.example");
  const std::string status = browser.read();
  EXPECT_NE(status.find("\"op\":\"status\""), std::string::npos) << status;
  EXPECT_NE(status.find("\"level\":2"), std::string::npos) << status;
  EXPECT_NE(status.find("log in first"), std::string::npos) << status;
  EXPECT_THROW(browser.read(), beast::system_error);
  EXPECT_EQ(browser.ws.reason().code, websocket::close_code::policy_error);
  EXPECT_EQ(std::string(browser.ws.reason().reason.data(), browser.ws.reason().reason.size()).rfind("log in first", 0),
            0u)
      << browser.ws.reason().reason.c_str();
  EXPECT_EQ(hub_.clients(), 0u) << "a refused connection never joins the hub";
}

TEST_F(ServerTest, LogoutTakesTheSessionAsGivenAndEndsItsConnections) {
  start({});
  auto login = request(http::verb::post, "/api/login", "{\"credential\":\"the-space-token\"}", "application/json");
  const auto at = login.body().find("\"session\":\"") + 11;
  const std::string session = login.body().substr(at, 32);
  WsClient foxglove;
  foxglove.connect(port(), "/?session=" + session);
  foxglove.read_until("advertise");
  ASSERT_TRUE(wait_until([&] { return hub_.clients() == 1; }, 5s));
  EXPECT_EQ(request(http::verb::post, "/api/logout", "{}", "application/json").result_int(), 400) << "no session named";
  auto out = request(http::verb::post, "/api/logout", "{\"session\":\"" + session + "\"}", "application/json");
  EXPECT_EQ(out.result_int(), 200);
  EXPECT_EQ(out.body(), "{\"ended\":true,\"connections\":1}");
  // The connection leaves the hub and ends, saying why (a connection left open would block the
  // reads below: the hub is asked first); the session is gone.
  ASSERT_TRUE(wait_until([&] { return hub_.clients() == 0; }, 5s)) << "the logged out connection left the hub";
  bool closed = false;
  for (int i = 0; i < 100 && !closed; ++i) {
    try {
      foxglove.read();
    } catch (const beast::system_error&) {
      closed = true;
    }
  }
  EXPECT_TRUE(closed);
  EXPECT_EQ(foxglove.ws.reason().code, websocket::close_code::policy_error);
  EXPECT_EQ(std::string(foxglove.ws.reason().reason.data(), foxglove.ws.reason().reason.size()),
            "logged out: log in again for a new session");
  WsClient again;
  EXPECT_THROW(again.connect(port(), "/?session=" + session), beast::system_error);
  auto twice = request(http::verb::post, "/api/logout?session=" + session, "{}", "application/json");
  EXPECT_EQ(twice.body(), "{\"ended\":false,\"connections\":0}");
}

TEST_F(ServerTest, ASlowClientIsDroppedWhileAFastOneKeepsReceiving) {
  gw::ServerOptions options;
  options.anonymous = gw::Role::viewer;
  options.max_queue_bytes = 512 * 1024;
  start(options);
  const uint32_t flood = hub_.add_channel({"/flood", "T", "{}", gw::Latch::none, 0});
  const std::string subscribe =
      "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":1,\"channelId\":" + std::to_string(flood) + "}]}";
  WsClient fast;
  fast.connect(port());
  fast.read_until("advertise");
  fast.ws.write(net::buffer(subscribe));
  WsClient slow;
  slow.connect(port(), "/", 4096);  // a small receive buffer, and it never reads again
  slow.read_until("advertise");
  slow.ws.write(net::buffer(subscribe));
  ASSERT_TRUE(wait_until([&] { return hub_.subscribers(flood) == 2; }, 5s));

  std::atomic<uint64_t> received{0};
  std::atomic<bool> in_order{true};
  std::thread reader([&] {
    uint64_t expected = 0;
    try {
      while (true) {
        const std::string message = fast.read();
        if (fast.ws.got_text()) continue;
        const uint64_t seq = std::stoull(message.substr(13, 20));
        if (seq != expected) in_order = false;
        expected = seq + 1;
        ++received;
      }
    } catch (const std::exception&) {
    }
  });
  // 64 KiB messages at the pace the fast client reads them (never more than 4 ahead of it, far
  // under its queue's limit), until the slow client, which reads nothing, is gone.
  const auto started = std::chrono::steady_clock::now();
  uint64_t seq = 0;
  while (hub_.clients() == 2 && std::chrono::steady_clock::now() - started < 60s) {
    if (!wait_until([&] { return received + 4 > seq; }, 10s)) break;
    char head[21];
    std::snprintf(head, sizeof head, "%020llu", static_cast<unsigned long long>(seq++));
    hub_.publish(flood, std::make_shared<const std::string>(std::string(head) + std::string(64 * 1024, 'x')), 0);
  }
  EXPECT_EQ(hub_.clients(), 1u) << "one client was dropped";
  EXPECT_EQ(hub_.subscribers(flood), 1u);
  // The fast client keeps receiving, every message in order.
  const uint64_t before = received;
  for (int i = 0; i < 50; ++i) {
    char head[21];
    std::snprintf(head, sizeof head, "%020llu", static_cast<unsigned long long>(seq++));
    hub_.publish(flood, std::make_shared<const std::string>(std::string(head) + "after"), 0);
  }
  EXPECT_TRUE(wait_until([&] { return received >= seq; }, 20s)) << received << " of " << seq;
  EXPECT_GT(received.load(), before);
  EXPECT_TRUE(in_order);
  // It was the slow one: the server ended its connection. (It could send no close frame: the
  // write in flight when it was dropped never drained; the connection was cut.)
  beast::error_code error;
  for (int i = 0; i < 100000 && !error; ++i) {
    slow.buffer.consume(slow.buffer.size());
    slow.ws.read(slow.buffer, error);
  }
  EXPECT_TRUE(error == websocket::error::closed || error == net::error::eof || error == net::error::connection_reset)
      << error.message();
  server_->stop();  // closes the fast client's connection too: its reader ends
  reader.join();
}

// ---- the DDS link ------------------------------------------------------------------------------------

namespace {
class RecordingSink : public gw::ViewSink {
 public:
  void services(const std::string& source, std::vector<gw::Service> now) override {
    std::lock_guard lock(mutex);
    services_[source] = std::move(now);
    ++reads;
  }
  void components(const std::string& source, std::vector<gw::Component> now) override {
    std::lock_guard lock(mutex);
    components_[source] = std::move(now);
  }
  void operations(const std::string&, std::vector<gw::Operation>) override {}
  void pose(const gw::Pose& pose) override {
    std::lock_guard lock(mutex);
    poses.push_back(pose);
  }
  void context(const gw::ContextEntry& entry) override {
    std::lock_guard lock(mutex);
    contexts.push_back(entry);
  }
  void event(const gw::Event& event) override {
    std::lock_guard lock(mutex);
    events.push_back(event);
  }
  std::vector<gw::Service> services(const std::string& source) {
    std::lock_guard lock(mutex);
    return services_[source];
  }
  std::vector<gw::Component> components(const std::string& source) {
    std::lock_guard lock(mutex);
    return components_[source];
  }
  std::mutex mutex;
  std::map<std::string, std::vector<gw::Service>> services_;
  std::map<std::string, std::vector<gw::Component>> components_;
  std::vector<gw::Pose> poses;
  std::vector<gw::ContextEntry> contexts;
  std::vector<gw::Event> events;
  std::atomic<int> reads{0};  // catalog reads reported
};

// The options of the DDS link of `space`'s bridge, named "bridge-<space>", in `domain`.
urs::federation::DdsOptions bridge_link_options(uint32_t domain, const std::string& space) {
  urs::federation::DdsOptions options;
  options.domain = domain;
  options.space = space;
  options.bridge = "bridge-" + space;
  return options;
}
}  // namespace

TEST(DdsSource, SeesAnotherSpacesBridgeAndLosesIt) {
  urs::test::DdsDomains domains(1);
  urs::federation::DdsOptions jp_options = bridge_link_options(domains[0], "jp");
  jp_options.lease = 1000ms;
  auto jp = std::make_unique<urs::federation::DdsLink>(
      jp_options, [] {}, [](urs::call::Request, urs::call::Responder) {});
  auto jp_state = std::make_unique<urs::federation::StateLink>(*jp, urs::federation::StateHandlers{}, std::nullopt);

  gw::DdsSourceOptions options;
  options.space = "kr";
  options.link.domain = domains[0];
  options.link.lease = 1000ms;
  RecordingSink sink;  // before the source: it outlives what the source reports into it
  gw::DdsSource source(options);
  source.start(sink);

  const auto* diagnostic = URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  jp->announce({"jp", "robot1.navigation", diagnostic->full_name(), "IDL:URS/Diagnostic:1.0",
                "rtc:jp1.host_cxt/Robot0.rtc:navigation", "bridge-jp", 15000,
                urs::schema::descriptor_set_for(*diagnostic->file())});
  jp_state->set_component({"jp", "jp1.host_cxt/Robot0.rtc", "rtc", "Active", "Robot", "jp1", {}});
  ASSERT_TRUE(wait_until([&] { return !sink.services("dds").empty() && !sink.components("dds").empty(); }, 20s));
  const gw::Service service = sink.services("dds").front();
  EXPECT_EQ(service.space(), "jp");
  EXPECT_EQ(service.name(), "robot1.navigation");
  EXPECT_EQ(service.origin(), "rtc:jp1.host_cxt/Robot0.rtc:navigation");
  EXPECT_EQ(service.bridge(), "bridge-jp");
  EXPECT_EQ(service.seen_via(), "dds");
  const gw::Component component = sink.components("dds").front();
  EXPECT_EQ(component.name(), "jp1.host_cxt/Robot0.rtc");
  EXPECT_EQ(component.state(), "Active");

  // Context and events of jp, payloads decoded with the description the catalog carried.
  jp_state->set_context({"", "robot1.battery", "{\"level\":0.8}", "sam@jp", 3, {}});
  URS::Diagnostic_echo_Request payload;
  payload.set_text("from jp");
  ASSERT_TRUE(wait_until(
      [&] {
        jp_state->publish_event({"", 7, "jp/test", "URS.Diagnostic_echo_Request", "sam@jp",
                                 std::chrono::system_clock::now(), payload.SerializeAsString()});
        std::lock_guard lock(sink.mutex);
        return !sink.events.empty() && !sink.contexts.empty();
      },
      20s));
  {
    std::lock_guard lock(sink.mutex);
    EXPECT_EQ(sink.events.front().space(), "jp");
    EXPECT_EQ(sink.events.front().payload().struct_value().fields().at("text").string_value(), "from jp");
    EXPECT_EQ(sink.contexts.front().key(), "robot1.battery");
    EXPECT_EQ(sink.contexts.front().value().struct_value().fields().at("level").number_value(), 0.8);
  }

  // jp's bridge leaves: its services and components leave the picture.
  jp_state.reset();
  jp.reset();
  EXPECT_TRUE(wait_until([&] { return sink.services("dds").empty() && sink.components("dds").empty(); }, 20s));
  source.stop();
}

// A peer whose name resolves only after the gateway started (between containers: the bridge's
// container started later). The gateway keeps serving without the link meanwhile and joins it
// once the name resolves. The source runs in a child process forked before any thread, in a mount
// namespace of its own over a hosts file the test writes; the child tells what it sees through a
// pipe. Without the right to make a mount namespace (not root), or in a process that already runs
// threads (a forked child would inherit Fast DDS's state without them; ctest runs each test alone),
// the test is skipped.
TEST(DdsSource, JoinsTheLinkOnceItsPeersNameResolves) {
  const auto threads = std::distance(std::filesystem::directory_iterator("/proc/self/task"), {});
  if (threads > 1) GTEST_SKIP() << "run it alone: this process already runs " << threads << " threads";
  urs::test::DdsDomains domains(1);
  const std::string dir = urs::test::make_temp_dir("gateway-hosts");
  const std::string hosts = dir + "/hosts";
  std::filesystem::copy_file("/etc/hosts", hosts);
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(pipe_fds[0]);
    const auto say = [&](const std::string& line) {
      const std::string text = line + "\n";
      [[maybe_unused]] const auto written = write(pipe_fds[1], text.data(), text.size());
    };
    if (unshare(CLONE_NEWNS) != 0 || mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
        mount(hosts.c_str(), "/etc/hosts", nullptr, MS_BIND, nullptr) != 0) {
      say(std::string("skip: no private /etc/hosts here: ") + std::strerror(errno));
      _exit(0);
    }
    gw::DdsSourceOptions options;
    options.space = "kr";
    options.link.domain = domains[0];
    options.link.lease = 1000ms;
    options.link.udp_only = true;
    options.link.initial_peers = {"jp-bridge-later"};
    RecordingSink sink;
    gw::DdsSource source(options);
    try {
      source.start(sink);
    } catch (const std::exception& e) {
      say(std::string("start threw: ") + e.what());
      _exit(1);
    }
    say("started");
    const bool seen = wait_until([&] { return !sink.services("dds").empty(); }, 60s);
    say(seen ? "seen " + sink.services("dds").front().space() + "/" + sink.services("dds").front().name() : "nothing");
    source.stop();
    _exit(0);
  }
  close(pipe_fds[1]);
  std::string received;
  // The child's next line, or "" when none came within `limit`.
  const auto next_line = [&](std::chrono::milliseconds limit) -> std::string {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (received.find('\n') == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return "";
      pollfd readable{pipe_fds[0], POLLIN, 0};
      if (poll(&readable, 1, static_cast<int>(left.count())) <= 0) continue;
      char buffer[256];
      const ssize_t n = read(pipe_fds[0], buffer, sizeof buffer);
      if (n <= 0) return "";
      received.append(buffer, static_cast<size_t>(n));
    }
    const auto newline = received.find('\n');
    std::string line = received.substr(0, newline);
    received.erase(0, newline + 1);
    return line;
  };
  const auto finish = [&] {
    kill(child, SIGTERM);
    int status = 0;
    waitpid(child, &status, 0);
    close(pipe_fds[0]);
    std::filesystem::remove_all(dir);
  };

  const std::string started = next_line(20s);
  if (started.rfind("skip", 0) == 0) {
    finish();
    GTEST_SKIP() << started;
  }
  ASSERT_EQ(started, "started") << "the source must start without its peer's name";
  urs::federation::DdsOptions jp_options = bridge_link_options(domains[0], "jp");
  jp_options.lease = 1000ms;
  jp_options.udp_only = true;
  urs::federation::DdsLink jp(
      jp_options, [] {}, [](urs::call::Request, urs::call::Responder) {});
  const auto* diagnostic = URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  jp.announce({"jp", "robot1.navigation", diagnostic->full_name(), "IDL:URS/Diagnostic:1.0", "rtc:x", "bridge-jp", 0,
               urs::schema::descriptor_set_for(*diagnostic->file())});
  EXPECT_EQ(next_line(3s), "") << "no link before the peer's name resolves";

  std::ofstream(hosts, std::ios::app) << "127.0.0.1 jp-bridge-later\n";  // the same file: the bind mount sees it
  EXPECT_EQ(next_line(45s), "seen jp/robot1.navigation");
  finish();
}

TEST(DdsSource, LeavesOutWhatTheOwnSpacesNativeSourcesShow) {
  urs::test::DdsDomains domains(1);
  urs::federation::DdsLink kr(
      bridge_link_options(domains[0], "kr"), [] {}, [](urs::call::Request, urs::call::Responder) {});
  urs::federation::DdsLink jp(
      bridge_link_options(domains[0], "jp"), [] {}, [](urs::call::Request, urs::call::Responder) {});
  const auto* diagnostic = URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  const std::string described = urs::schema::descriptor_set_for(*diagnostic->file());
  kr.announce({"kr", "diag", diagnostic->full_name(), "IDL:URS/Diagnostic:1.0", "camus", "bridge-kr", 0, described});
  jp.announce({"jp", "diag", diagnostic->full_name(), "IDL:URS/Diagnostic:1.0", "rtc:x", "bridge-jp", 0, described});

  gw::DdsSourceOptions options;
  options.space = "kr";
  options.link.domain = domains[0];
  RecordingSink all_sink, others_sink;  // before the sources, which report into them
  gw::DdsSource everything(options);    // a gateway of kr that reads kr's entries on the link too
  options.own_services = false;         // one whose CAMUS server shows kr's services
  gw::DdsSource others(options);
  everything.start(all_sink);
  others.start(others_sink);
  ASSERT_TRUE(
      wait_until([&] { return all_sink.services("dds").size() == 2 && !others_sink.services("dds").empty(); }, 20s));
  // Both entries were in the domain and each source had matched the writers by then: three more
  // reads of the other source saw them too (each participant discovers the others at its own pace,
  // so it is the other source's own arrival of jp's entry that says it has).
  const int reads = others_sink.reads;
  ASSERT_TRUE(wait_until([&] { return others_sink.reads >= reads + 3; }, 20s));
  const auto seen = others_sink.services("dds");
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen.front().space(), "jp");
  others.stop();
  everything.stop();
}
