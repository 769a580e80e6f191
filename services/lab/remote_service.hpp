#pragma once
// One service as a client of the experiments uses it, whichever world it is reached in: a CAMUS
// service over Planet (through the CAMUS server, so through the bridge for an RT provider it
// offers), or an RT provider port called directly over CORBA (DII from the interface's
// description, as any RT consumer). Both take and give the same Protobuf messages.

#include <google/protobuf/message.h>

#include <chrono>
#include <memory>
#include <string>

#include "urs/planet/status.hpp"

namespace urs::planet {
class Client;
}
namespace urs::rtc {
class Orb;
class NamingClient;
}  // namespace urs::rtc

namespace urs::lab {

class RemoteService {
 public:
  virtual ~RemoteService() = default;
  // Calls `operation`; on OK `reply` is filled. Never throws for a remote failure.
  virtual planet::CallResult call(const std::string& operation, const google::protobuf::Message& request,
                                  google::protobuf::Message& reply, std::chrono::milliseconds deadline) = 0;
  virtual std::string where() const = 0;
};

// `service` on the CAMUS server `client` is connected to.
std::unique_ptr<RemoteService> camus_service(planet::Client& client, const std::string& service);

// The provider port "PATH:PORT" in the naming service, for `interface` (a Protobuf service
// generated from IDL, e.g. URC.Navigation). Throws std::runtime_error if the port cannot be found
// or provides no such interface.
std::unique_ptr<RemoteService> rt_provider(rtc::Orb& orb, rtc::NamingClient& naming, const std::string& port_address,
                                           const google::protobuf::ServiceDescriptor& interface);

// Throws std::runtime_error "<what>: <status> <message>" unless `result` is OK.
void expect_ok(const planet::CallResult& result, const std::string& what);

}  // namespace urs::lab
