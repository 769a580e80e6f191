// tcp-rtt: the raw TCP round trip of a path, the floor a call over that path is measured against
// (urs-bench's WAN rows, tests/e2e/sites). Test support, not product.
//
//   tcp-rtt --serve [HOST:]PORT [--ready-file PATH]
//       answers each length-prefixed message on every connection (a thread per connection): a
//       4-byte message asks for a reply of that many bytes, any other is echoed (raw_tcp.hpp)
//   tcp-rtt --serve-over HOST:PORT [--clients N]
//       answers the same way on N connections it opens to HOST:PORT, and exits once they are all
//       closed: the server of a round trip over connections opened from this side, as a site behind
//       NAT opens the link's (urs-wan-bench --raw-accept)
//   tcp-rtt --connect HOST:PORT [--request-bytes N] [--reply-bytes N] [--count N] [--clients N]
//       N round trips per client over one connection each (TCP_NODELAY); prints
//       "rtt count=.. p50_us=.. p90_us=.. max_us=.. calls_per_s=.." (calls_per_s: all clients)
//       and exits 1 when the connection fails or breaks.

#include <netdb.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "raw_tcp.hpp"

namespace {

using Clock = std::chrono::steady_clock;

sockaddr_in address_of(const std::string& host_port, bool passive) {
  const auto colon = host_port.rfind(':');
  const std::string host = colon == std::string::npos ? "" : host_port.substr(0, colon);
  const std::string port = colon == std::string::npos ? host_port : host_port.substr(colon + 1);
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = passive ? AI_PASSIVE : 0;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.empty() ? nullptr : host.c_str(), port.c_str(), &hints, &found) != 0 || found == nullptr) {
    throw std::runtime_error("cannot resolve " + host_port);
  }
  sockaddr_in address{};
  std::memcpy(&address, found->ai_addr, sizeof address);
  freeaddrinfo(found);
  return address;
}

int serve(const std::string& where, const std::string& ready_file) {
  const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
  int one = 1;
  ::setsockopt(listener, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in address = address_of(where, true);
  if (::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(listener, 64) != 0) {
    std::cerr << "tcp-rtt: cannot listen on " << where << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";
  for (;;) {
    const int fd = ::accept(listener, nullptr, nullptr);
    if (fd < 0) continue;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::thread([fd] {
      urs::bench::serve_echo(fd);
      ::close(fd);
    }).detach();
  }
}

int serve_over(const std::string& where, int connections) {
  const sockaddr_in address = address_of(where, false);
  std::vector<int> fds;
  for (int c = 0; c < connections; ++c) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    fds.push_back(fd);
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      std::cerr << "tcp-rtt: cannot connect to " << where << ": " << std::strerror(errno) << "\n";
      for (const int opened : fds) ::close(opened);
      return 1;
    }
    int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  std::vector<std::thread> threads;
  for (const int fd : fds) {
    threads.emplace_back([fd] {
      urs::bench::serve_echo(fd);
      ::close(fd);
    });
  }
  for (auto& thread : threads) thread.join();
  return 0;
}

int measure(const std::string& where, std::size_t request_bytes, std::size_t reply_bytes, int count, int clients) {
  const sockaddr_in address = address_of(where, false);
  // A request that asks for reply_bytes (4 bytes) when the reply is to differ from the request.
  const std::string request = reply_bytes != request_bytes
                                  ? urs::bench::blob_request(static_cast<uint32_t>(reply_bytes))
                                  : std::string(request_bytes, 'q');
  std::mutex mutex;
  std::vector<long> rtts_us;
  bool failed = false;
  const auto start = Clock::now();
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&] {
      const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
      int one = 1;
      if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
        std::lock_guard lock(mutex);
        std::cerr << "tcp-rtt: cannot connect to " << where << ": " << std::strerror(errno) << "\n";
        failed = true;
        ::close(fd);
        return;
      }
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      std::vector<long> mine;
      std::string reply;
      for (int i = 0; i < count; ++i) {
        const auto sent = Clock::now();
        if (!urs::bench::send_message(fd, request.data(), static_cast<uint32_t>(request.size())) ||
            !urs::bench::recv_message(fd, reply)) {
          std::lock_guard lock(mutex);
          std::cerr << "tcp-rtt: the connection to " << where << " broke after " << i << " round trips\n";
          failed = true;
          break;
        }
        mine.push_back(
            static_cast<long>(std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - sent).count()));
      }
      ::close(fd);
      std::lock_guard lock(mutex);
      rtts_us.insert(rtts_us.end(), mine.begin(), mine.end());
    });
  }
  for (auto& thread : threads) thread.join();
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (failed || rtts_us.empty()) return 1;
  std::sort(rtts_us.begin(), rtts_us.end());
  auto pct = [&](double p) {
    return rtts_us[std::min(rtts_us.size() - 1, static_cast<std::size_t>(p * rtts_us.size()))];
  };
  std::cout << "rtt count=" << rtts_us.size() << " p50_us=" << pct(0.5) << " p90_us=" << pct(0.9)
            << " max_us=" << rtts_us.back() << " calls_per_s=" << static_cast<long>(rtts_us.size() / seconds) << "\n";
  return 0;
}

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "tcp-rtt: " << why
            << "\nusage: tcp-rtt --serve [HOST:]PORT [--ready-file PATH]\n"
               "       tcp-rtt --serve-over HOST:PORT [--clients N]\n"
               "       tcp-rtt --connect HOST:PORT [--request-bytes N] [--reply-bytes N] [--count N] [--clients N]\n";
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  std::string serve_at, serve_over_to, connect_to, ready_file;
  std::size_t request_bytes = 64, reply_bytes = 64;
  int count = 20, clients = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) usage(flag + " needs a value");
    const std::string value = argv[++i];
    if (flag == "--serve")
      serve_at = value;
    else if (flag == "--serve-over")
      serve_over_to = value;
    else if (flag == "--connect")
      connect_to = value;
    else if (flag == "--ready-file")
      ready_file = value;
    else if (flag == "--request-bytes")
      request_bytes = std::stoul(value);
    else if (flag == "--reply-bytes")
      reply_bytes = std::stoul(value);
    else if (flag == "--count")
      count = std::stoi(value);
    else if (flag == "--clients")
      clients = std::stoi(value);
    else
      usage("unknown flag " + flag);
  }
  if (!serve_at.empty() + !serve_over_to.empty() + !connect_to.empty() != 1) {
    usage("one of --serve, --serve-over and --connect");
  }
  try {
    if (!serve_at.empty()) return serve(serve_at, ready_file);
    if (!serve_over_to.empty()) return serve_over(serve_over_to, clients);
    return measure(connect_to, request_bytes, reply_bytes, count, clients);
  } catch (const std::exception& e) {
    std::cerr << "tcp-rtt: " << e.what() << "\n";
    return 1;
  }
}
