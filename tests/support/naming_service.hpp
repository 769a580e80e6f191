#pragma once
// A real omniNames for integration tests: started on a free loopback port with its own data
// directory, ready when it accepts TCP connections, killed when the object goes.

#include <memory>
#include <string>

#include "process.hpp"

namespace urs::test {

class NamingService {
 public:
  // Starts omniNames with its log under `dir` (created if missing). Throws std::runtime_error if
  // it does not come up.
  explicit NamingService(const std::string& dir);

  int port() const { return port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  std::string log() const { return process_ ? process_->log() : std::string(); }

 private:
  int port_ = 0;
  std::unique_ptr<Process> process_;
};

// A TCP port on 127.0.0.1 that nothing listens on at the time of the call.
int free_tcp_port();
// True if something accepts TCP connections on 127.0.0.1:`port`.
bool accepts_tcp(int port);

}  // namespace urs::test
