// wan-delay: holds every packet of an NFQUEUE queue for a fixed time, then lets it go, so that a
// network namespace's forwarding path gets a WAN's latency on a kernel without the netem qdisc.
// Test support (tests/e2e/sites/wan.sh), not product.
//
//   wan-delay --queue N --delay-ms D [--ready-file PATH]
//
// Run inside the namespace whose rule sends packets to queue N (iptables ... -j NFQUEUE
// --queue-num N). Speaks nfnetlink_queue directly (no library): binds the queue in metadata-only
// mode (the kernel copies no payload, only the packet's id), takes packets in the order the kernel
// queued them and, since every packet waits the same time, accepts them in that order with one
// batch verdict for all those that are due (a verdict on id n covers every earlier id). Order is
// kept, nothing is rewritten. Packets the kernel cannot queue (the queue or this socket full) are
// dropped by the kernel, as a full router buffer drops them; the count of queue overruns seen is
// printed at exit. Exits on SIGTERM or SIGINT, unbinding the queue (packets still held are then
// dropped by the kernel).

#include <arpa/inet.h>
#include <linux/netfilter.h>
#include <linux/netfilter/nfnetlink.h>
#include <linux/netfilter/nfnetlink_queue.h>
#include <linux/netlink.h>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Held {
  uint32_t id;
  Clock::time_point due;
};

// One nfnetlink message: header, nfgenmsg, then attributes appended with add().
class Message {
 public:
  Message(uint16_t type, uint16_t queue, uint16_t flags) : bytes_(NLMSG_HDRLEN + NLMSG_ALIGN(sizeof(nfgenmsg))) {
    auto* header = reinterpret_cast<nlmsghdr*>(bytes_.data());
    header->nlmsg_type = static_cast<uint16_t>((NFNL_SUBSYS_QUEUE << 8) | type);
    header->nlmsg_flags = static_cast<uint16_t>(NLM_F_REQUEST | flags);
    auto* generic = reinterpret_cast<nfgenmsg*>(bytes_.data() + NLMSG_HDRLEN);
    generic->nfgen_family = AF_UNSPEC;
    generic->version = NFNETLINK_V0;
    generic->res_id = htons(queue);
  }
  void add(uint16_t type, const void* data, std::size_t size) {
    const std::size_t at = bytes_.size();
    bytes_.resize(at + NLA_ALIGN(NLA_HDRLEN + size));
    auto* attribute = reinterpret_cast<nlattr*>(bytes_.data() + at);
    attribute->nla_type = type;
    attribute->nla_len = static_cast<uint16_t>(NLA_HDRLEN + size);
    std::memcpy(bytes_.data() + at + NLA_HDRLEN, data, size);
  }
  bool send(int fd) {
    auto* header = reinterpret_cast<nlmsghdr*>(bytes_.data());
    header->nlmsg_len = static_cast<uint32_t>(bytes_.size());
    sockaddr_nl kernel{};
    kernel.nl_family = AF_NETLINK;
    return ::sendto(fd, bytes_.data(), bytes_.size(), 0, reinterpret_cast<sockaddr*>(&kernel), sizeof kernel) ==
           static_cast<ssize_t>(bytes_.size());
  }

 private:
  std::vector<char> bytes_;
};

// Sends a configuration message and waits for the kernel's acknowledgement; false (and why) when
// it refuses.
bool configure(int fd, Message message, const char* what) {
  if (!message.send(fd)) {
    std::cerr << "wan-delay: cannot send " << what << ": " << std::strerror(errno) << "\n";
    return false;
  }
  char buffer[4096];
  const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
  if (n < static_cast<ssize_t>(NLMSG_HDRLEN)) {
    std::cerr << "wan-delay: no answer to " << what << "\n";
    return false;
  }
  const auto* header = reinterpret_cast<const nlmsghdr*>(buffer);
  if (header->nlmsg_type == NLMSG_ERROR) {
    const auto* error = reinterpret_cast<const nlmsgerr*>(NLMSG_DATA(header));
    if (error->error != 0) {
      std::cerr << "wan-delay: " << what << " refused: " << std::strerror(-error->error) << "\n";
      return false;
    }
  }
  return true;
}

// The ids of the packets in one buffer read from the socket, in order.
void packet_ids(const char* buffer, ssize_t size, std::vector<uint32_t>& ids) {
  for (auto* header = reinterpret_cast<const nlmsghdr*>(buffer); NLMSG_OK(header, static_cast<uint32_t>(size));
       header = NLMSG_NEXT(header, size)) {
    if ((header->nlmsg_type & 0xff) != NFQNL_MSG_PACKET || (header->nlmsg_type >> 8) != NFNL_SUBSYS_QUEUE) continue;
    const char* at = reinterpret_cast<const char*>(NLMSG_DATA(header)) + NLMSG_ALIGN(sizeof(nfgenmsg));
    const char* end = reinterpret_cast<const char*>(header) + header->nlmsg_len;
    while (at + NLA_HDRLEN <= end) {
      const auto* attribute = reinterpret_cast<const nlattr*>(at);
      if (attribute->nla_len < NLA_HDRLEN || at + attribute->nla_len > end) break;
      if ((attribute->nla_type & NLA_TYPE_MASK) == NFQA_PACKET_HDR &&
          attribute->nla_len >= NLA_HDRLEN + sizeof(nfqnl_msg_packet_hdr)) {
        nfqnl_msg_packet_hdr packet{};
        std::memcpy(&packet, at + NLA_HDRLEN, sizeof packet);
        ids.push_back(ntohl(packet.packet_id));
        break;
      }
      at += NLA_ALIGN(attribute->nla_len);
    }
  }
}

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "wan-delay: " << why << "\nusage: wan-delay --queue N --delay-ms D [--ready-file PATH]\n";
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  long queue = -1;
  long delay_ms = -1;
  std::string ready_file;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) usage(flag + " needs a value");
    const std::string value = argv[++i];
    if (flag == "--queue")
      queue = std::stol(value);
    else if (flag == "--delay-ms")
      delay_ms = std::stol(value);
    else if (flag == "--ready-file")
      ready_file = value;
    else
      usage("unknown flag " + flag);
  }
  if (queue < 0 || queue > 65535 || delay_ms < 0) usage("--queue 0..65535 and --delay-ms >= 0 are required");

  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  sigprocmask(SIG_BLOCK, &stop_signals, nullptr);
  const int stop_fd = signalfd(-1, &stop_signals, SFD_CLOEXEC);

  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_NETFILTER);
  if (fd < 0) {
    std::cerr << "wan-delay: netlink socket: " << std::strerror(errno) << "\n";
    return 1;
  }
  // Room for a WAN's worth of packets in flight; the kernel reports an overrun (ENOBUFS) when the
  // socket is full anyway.
  const int buffer_bytes = 64 << 20;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &buffer_bytes, sizeof buffer_bytes);
  sockaddr_nl local{};
  local.nl_family = AF_NETLINK;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) {
    std::cerr << "wan-delay: bind: " << std::strerror(errno) << "\n";
    return 1;
  }
  const auto queue_number = static_cast<uint16_t>(queue);
  {
    Message bind(NFQNL_MSG_CONFIG, queue_number, NLM_F_ACK);
    nfqnl_msg_config_cmd command{};
    command.command = NFQNL_CFG_CMD_BIND;
    bind.add(NFQA_CFG_CMD, &command, sizeof command);
    if (!configure(fd, bind, "binding the queue")) return 1;
  }
  {
    Message params(NFQNL_MSG_CONFIG, queue_number, NLM_F_ACK);
    nfqnl_msg_config_params mode{};
    mode.copy_mode = NFQNL_COPY_META;  // the packet id is all it needs
    mode.copy_range = htonl(0);
    params.add(NFQA_CFG_PARAMS, &mode, sizeof mode);
    const uint32_t max_length = htonl(1u << 16);
    params.add(NFQA_CFG_QUEUE_MAXLEN, &max_length, sizeof max_length);
    // GSO packets queued whole (no segmentation for a stage that only delays them).
    const uint32_t flags = htonl(NFQA_CFG_F_GSO);
    params.add(NFQA_CFG_MASK, &flags, sizeof flags);
    params.add(NFQA_CFG_FLAGS, &flags, sizeof flags);
    if (!configure(fd, params, "configuring the queue")) return 1;
  }
  if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";

  const auto delay = std::chrono::milliseconds(delay_ms);
  std::deque<Held> held;
  std::vector<uint32_t> ids;
  std::vector<char> buffer(1 << 20);
  unsigned long long passed = 0;
  unsigned long long overruns = 0;
  for (;;) {
    int timeout = -1;
    if (!held.empty()) {
      const auto wait = std::chrono::ceil<std::chrono::milliseconds>(held.front().due - Clock::now()).count();
      timeout = static_cast<int>(std::max<long long>(0, wait));
    }
    pollfd fds[2] = {{fd, POLLIN, 0}, {stop_fd, POLLIN, 0}};
    if (::poll(fds, 2, timeout) < 0 && errno != EINTR) break;
    if ((fds[1].revents & POLLIN) != 0) break;
    if ((fds[0].revents & POLLIN) != 0) {
      // Everything waiting, without blocking.
      for (;;) {
        const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
        if (n < 0) {
          if (errno == ENOBUFS) {
            ++overruns;
            continue;
          }
          break;
        }
        ids.clear();
        packet_ids(buffer.data(), n, ids);
        const auto now = Clock::now();
        for (uint32_t id : ids) held.push_back({id, now + delay});
      }
    }
    // Every packet that is due, with one verdict for the last of them.
    const auto now = Clock::now();
    uint32_t last = 0;
    bool any = false;
    while (!held.empty() && held.front().due <= now) {
      last = held.front().id;
      any = true;
      held.pop_front();
      ++passed;
    }
    if (any) {
      Message verdict(NFQNL_MSG_VERDICT_BATCH, queue_number, 0);
      nfqnl_msg_verdict_hdr accept{};
      accept.verdict = htonl(NF_ACCEPT);
      accept.id = htonl(last);
      verdict.add(NFQA_VERDICT_HDR, &accept, sizeof accept);
      if (!verdict.send(fd)) std::cerr << "wan-delay: verdict not sent: " << std::strerror(errno) << "\n";
    }
  }
  Message unbind(NFQNL_MSG_CONFIG, queue_number, 0);
  nfqnl_msg_config_cmd command{};
  command.command = NFQNL_CFG_CMD_UNBIND;
  unbind.add(NFQA_CFG_CMD, &command, sizeof command);
  unbind.send(fd);
  std::cout << "wan-delay: " << passed << " packets passed, " << held.size() << " held at exit, " << overruns
            << " queue overruns" << std::endl;
  ::close(fd);
  return 0;
}
