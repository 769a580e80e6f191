// planet-bus-flood: floods a CAMUS server's event bus the way a hostile peer would, and reports
// what came back. It asserts nothing: the integration test (and an operator measuring a server)
// reads its one line of JSON.
//
//   planet-bus-flood --server 127.0.0.1:PORT [--token-file F] [--subscriptions 2000] [--sessions 2]
//                    [--events 50000] [--levels 32] [--timeout-s 300]
//
// 1. `sessions` connections hold `subscriptions` patterns that never match the flood topic (they
//    share its first levels and differ in the last one).
// 2. A witness connection subscribes to the flood topic itself.
// 3. One connection writes all `events` Publish frames (ids 1..N) without waiting, and counts the
//    PublishAcks: OK, RESOURCE_EXHAUSTED, other.
// 4. It waits until every Publish is acknowledged and the witness has every event acknowledged OK.
//
// Output: {"events":N,"ok":..,"exhausted":..,"other":..,"ack_s":..,"delivered":..,"missing":..,
//          "unacked_delivered":..,"deliver_s":..,"ok_per_s":..,"subscribed":..,"exhausted_message":".."}
// Every connection answers Pings, so the server's heartbeats keep it open.

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "urs/planet/codec.hpp"

namespace {

using Clock = std::chrono::steady_clock;
namespace planet = urs::planet;

// One connection: a reader thread answers Pings and hands every other frame to `on_frame`;
// writes are serialized by a mutex.
class Connection {
 public:
  Connection(const std::string& host, uint16_t port, std::function<void(planet::Frame&&)> on_frame)
      : on_frame_(std::move(on_frame)) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    if (::inet_pton(AF_INET, host.c_str(), &address.sin_addr) != 1 ||
        ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("cannot connect to " + host + ":" + std::to_string(port));
    }
    int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~Connection() {
    stop_ = true;
    ::shutdown(fd_, SHUT_RDWR);
    if (reader_.joinable()) reader_.join();
    ::close(fd_);
  }

  // Sends Hello and waits for the Welcome; then starts the reader. Throws if refused.
  void open(const std::string& token, const std::string& name) {
    planet::Frame hello;
    hello.mutable_hello()->set_version(planet::kProtocolVersion);
    hello.mutable_hello()->set_token(token);
    hello.mutable_hello()->set_peer_name(name);
    hello.mutable_hello()->set_role(planet::CLIENT);
    send(hello);
    planet::MessageDecoder& decoder = *decoder_;
    std::optional<planet::Frame> first;
    char buffer[65536];
    while (!first) {
      const ssize_t got = ::recv(fd_, buffer, sizeof buffer, 0);
      if (got <= 0) throw std::runtime_error("connection closed during the handshake");
      decoder.feed(std::string_view(buffer, static_cast<size_t>(got)), [&](planet::Frame&& frame) {
        if (!first) {
          first = std::move(frame);
        } else {
          early_.push_back(std::move(frame));
        }
      });
    }
    if (!first->has_welcome()) throw std::runtime_error("not welcomed: " + first->ShortDebugString());
    reader_ = std::thread([this] { read(*decoder_); });
  }

  void send(const planet::Frame& frame) { send_bytes(planet::encode_frame(frame)); }
  void send_bytes(const std::string& bytes) {
    std::lock_guard<std::mutex> lock(write_mutex_);
    size_t offset = 0;
    while (offset < bytes.size()) {
      const ssize_t sent = ::send(fd_, bytes.data() + offset, bytes.size() - offset, MSG_NOSIGNAL);
      if (sent <= 0) return;
      offset += static_cast<size_t>(sent);
    }
  }
  bool closed() const { return closed_; }

 private:
  void read(planet::MessageDecoder& decoder) {
    for (auto& frame : early_) handle(std::move(frame));
    early_.clear();
    char buffer[65536];
    while (!stop_) {
      const ssize_t got = ::recv(fd_, buffer, sizeof buffer, 0);
      if (got <= 0) break;
      try {
        decoder.feed(std::string_view(buffer, static_cast<size_t>(got)),
                     [this](planet::Frame&& frame) { handle(std::move(frame)); });
      } catch (const planet::ProtocolError&) {
        break;
      }
    }
    closed_ = true;
  }
  void handle(planet::Frame&& frame) {
    if (frame.has_ping()) {
      planet::Frame pong;
      pong.mutable_pong()->set_nonce(frame.ping().nonce());
      send(pong);
      return;
    }
    on_frame_(std::move(frame));
  }

  int fd_ = -1;
  std::function<void(planet::Frame&&)> on_frame_;
  std::vector<planet::Frame> early_;
  static planet::CodecLimits reader_limits() {
    planet::CodecLimits limits;
    limits.max_frame_bytes = 64u << 20;  // whatever the server sends
    return limits;
  }
  std::unique_ptr<planet::MessageDecoder> decoder_ = std::make_unique<planet::MessageDecoder>(reader_limits());
  std::mutex write_mutex_;
  std::thread reader_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> closed_{false};
};

struct Options {
  std::string host = "127.0.0.1";
  uint16_t port = 0;
  std::string token;
  size_t subscriptions = 2000;
  size_t sessions = 2;
  size_t events = 50000;
  size_t levels = 32;
  int timeout_s = 300;
};

std::string json_text(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out + "\"";
}

int run(const Options& o) {
  std::string topic = "flood";
  for (size_t i = 1; i < o.levels; ++i) topic += "/l" + std::to_string(i);
  const std::string prefix = topic.substr(0, topic.rfind('/') + 1);

  std::mutex mutex;
  std::condition_variable changed;
  size_t subscribed = 0, refused_subscriptions = 0;
  size_t ok = 0, exhausted = 0, other = 0;
  std::string exhausted_message, other_message;
  std::set<uint64_t> ok_seqs, delivered;
  Clock::time_point last_ack, last_event;

  auto on_subscriber_frame = [&](planet::Frame&& frame) {
    if (!frame.has_subscribe_ack()) return;
    std::lock_guard<std::mutex> lock(mutex);
    (frame.subscribe_ack().status() == planet::OK ? subscribed : refused_subscriptions)++;
    changed.notify_all();
  };
  std::vector<std::unique_ptr<Connection>> holders;
  for (size_t s = 0; s < o.sessions; ++s) {
    holders.push_back(std::make_unique<Connection>(o.host, o.port, on_subscriber_frame));
    holders.back()->open(o.token, "flood-holder-" + std::to_string(s));
  }
  std::string subscribes;
  for (size_t i = 0; i < o.subscriptions; ++i) {
    planet::Frame frame;
    frame.mutable_subscribe()->set_subscription_id(i + 1);
    frame.mutable_subscribe()->set_pattern(prefix + "nomatch" + std::to_string(i));
    holders[i % o.sessions]->send(frame);
  }
  {
    std::unique_lock<std::mutex> lock(mutex);
    changed.wait_for(lock, std::chrono::seconds(o.timeout_s),
                     [&] { return subscribed + refused_subscriptions >= o.subscriptions; });
  }

  bool watching = false;
  Connection witness(o.host, o.port, [&](planet::Frame&& frame) {
    std::lock_guard<std::mutex> lock(mutex);
    if (frame.has_event()) {
      delivered.insert(frame.event().seq());
      last_event = Clock::now();
    }
    if (frame.has_subscribe_ack()) watching = frame.subscribe_ack().status() == planet::OK;
    changed.notify_all();
  });
  witness.open(o.token, "flood-witness");
  planet::Frame watch;
  watch.mutable_subscribe()->set_subscription_id(1);
  watch.mutable_subscribe()->set_pattern(topic);
  witness.send(watch);
  {
    std::unique_lock<std::mutex> lock(mutex);
    if (!changed.wait_for(lock, std::chrono::seconds(o.timeout_s), [&] { return watching; })) {
      throw std::runtime_error("the witness's subscription to " + topic + " was not accepted");
    }
  }

  Connection publisher(o.host, o.port, [&](planet::Frame&& frame) {
    if (!frame.has_publish_ack()) return;
    const auto& ack = frame.publish_ack();
    std::lock_guard<std::mutex> lock(mutex);
    if (ack.status() == planet::OK) {
      ++ok;
      ok_seqs.insert(ack.seq());
    } else if (ack.status() == planet::RESOURCE_EXHAUSTED) {
      ++exhausted;
      if (exhausted_message.empty()) exhausted_message = ack.message();
    } else {
      ++other;
      if (other_message.empty()) other_message = ack.message();
    }
    last_ack = Clock::now();
    changed.notify_all();
  });
  publisher.open(o.token, "flood-publisher");

  const auto start = Clock::now();
  std::string batch;
  for (size_t i = 1; i <= o.events; ++i) {
    planet::Frame frame;
    frame.mutable_publish()->set_publish_id(i);
    frame.mutable_publish()->set_topic(topic);
    frame.mutable_publish()->set_payload("event " + std::to_string(i));
    batch += planet::encode_frame(frame);
    if (batch.size() > (256u << 10) || i == o.events) {
      publisher.send_bytes(batch);
      batch.clear();
    }
  }
  bool complete = false;
  {
    std::unique_lock<std::mutex> lock(mutex);
    complete = changed.wait_for(lock, std::chrono::seconds(o.timeout_s), [&] {
      if (ok + exhausted + other < o.events) return false;
      for (uint64_t seq : ok_seqs) {
        if (!delivered.count(seq)) return false;
      }
      return true;
    });
  }
  std::lock_guard<std::mutex> lock(mutex);
  size_t missing = 0, unacked_delivered = 0;
  for (uint64_t seq : ok_seqs) missing += delivered.count(seq) ? 0 : 1;
  for (uint64_t seq : delivered) unacked_delivered += ok_seqs.count(seq) ? 0 : 1;
  auto seconds = [&](Clock::time_point t) {
    return t == Clock::time_point{} ? -1.0 : std::chrono::duration<double>(t - start).count();
  };
  const double ack_s = seconds(last_ack);
  std::ostringstream out;
  out << "{\"complete\":" << (complete ? "true" : "false") << ",\"events\":" << o.events << ",\"ok\":" << ok
      << ",\"exhausted\":" << exhausted << ",\"other\":" << other << ",\"ack_s\":" << ack_s
      << ",\"delivered\":" << delivered.size() << ",\"missing\":" << missing
      << ",\"unacked_delivered\":" << unacked_delivered << ",\"deliver_s\":" << seconds(last_event)
      << ",\"ok_per_s\":" << (ack_s > 0 ? static_cast<double>(ok) / ack_s : 0.0) << ",\"subscribed\":" << subscribed
      << ",\"refused_subscriptions\":" << refused_subscriptions
      << ",\"exhausted_message\":" << json_text(exhausted_message) << ",\"other_message\":" << json_text(other_message)
      << "}";
  std::cout << out.str() << std::endl;
  return complete ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
        return argv[++i];
      };
      if (arg == "--server") {
        const std::string v = value();
        o.host = v.substr(0, v.rfind(':'));
        o.port = static_cast<uint16_t>(std::stoi(v.substr(v.rfind(':') + 1)));
      } else if (arg == "--token-file") {
        std::ifstream in(value());
        std::getline(in, o.token);
      } else if (arg == "--subscriptions") {
        o.subscriptions = std::stoul(value());
      } else if (arg == "--sessions") {
        o.sessions = std::max<size_t>(1, std::stoul(value()));
      } else if (arg == "--events") {
        o.events = std::stoul(value());
      } else if (arg == "--levels") {
        o.levels = std::max<size_t>(2, std::stoul(value()));
      } else if (arg == "--timeout-s") {
        o.timeout_s = std::stoi(value());
      } else {
        throw std::invalid_argument("unknown argument " + arg);
      }
    }
    if (o.port == 0) throw std::invalid_argument("--server HOST:PORT is required");
    return run(o);
  } catch (const std::exception& e) {
    std::cerr << "planet-bus-flood: " << e.what() << "\n";
    return 2;
  }
}
