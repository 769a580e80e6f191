// calculator-client: calls the Calculator plug-in's agent through a CAMUS server from C++, with
// the classes generated from the example's IDL.
//   calculator-client --service NAME DIVIDEND DIVISOR [--server HOST:PORT] [--token-file FILE]
// Prints the quotient, then the agent's call count. Exit codes: 0 answered; 1 the call failed or
// raised DivisionByZero (printed on stderr); 2 bad arguments.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "Calculator.pb.h"
#include "urs/planet/client.hpp"
#include "urs/util/cli.hpp"

namespace {

// Calls `operation` and parses the reply into `reply`; false after printing why it failed.
bool call(urs::planet::Client& client, const std::string& service, const std::string& operation,
          const google::protobuf::Message& request, google::protobuf::Message& reply) {
  const auto result = client.call(service, operation, request.SerializeAsString(), std::chrono::seconds(5));
  if (result.status == urs::planet::USER_EXCEPTION &&
      result.exception_type == PluginExample::DivisionByZero::descriptor()->full_name()) {
    PluginExample::DivisionByZero refusal;
    refusal.ParseFromString(result.payload);
    std::fprintf(stderr, "calculator-client: DivisionByZero (dividend %g)\n", refusal.dividend());
    return false;
  }
  if (!result.ok() || !reply.ParseFromString(result.payload)) {
    std::fprintf(stderr, "calculator-client: %s failed: %s: %s\n", operation.c_str(),
                 std::string(urs::planet::status_name(result.status)).c_str(), result.message.c_str());
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string server = "127.0.0.1:7600";
  std::string service;
  std::string token_file;
  std::vector<std::string> numbers;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "--server" || arg == "--service" || arg == "--token-file") && i + 1 < argc) {
      (arg == "--server" ? server : arg == "--service" ? service : token_file) = argv[++i];
    } else {
      numbers.push_back(arg);
    }
  }
  urs::planet::ClientOptions options;
  PluginExample::Calculator_divide_Request request;
  try {
    if (service.empty() || numbers.size() != 2) throw std::invalid_argument("give --service NAME DIVIDEND DIVISOR");
    urs::util::init_logging("calculator-client", "warn");  // the log goes to stderr
    request.set_dividend(std::stod(numbers[0]));
    request.set_divisor(std::stod(numbers[1]));
    const auto endpoint = urs::util::parse_endpoint(server, "--server");
    options.host = endpoint.host;
    options.port = endpoint.port;
    options.token = urs::util::read_token_file(token_file);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "usage: %s --service NAME DIVIDEND DIVISOR [--server HOST:PORT] [--token-file FILE]: %s\n",
                 argv[0], e.what());
    return 2;
  }
  options.peer_name = "calculator-client";

  urs::planet::Client client(options);
  client.start();
  PluginExample::Calculator_divide_Reply quotient;
  PluginExample::Calculator_calls_Reply calls;
  const bool ok = call(client, service, "divide", request, quotient) &&
                  call(client, service, "calls", PluginExample::Calculator_calls_Request(), calls);
  client.stop();
  if (!ok) return 1;
  std::printf("%g\n%u\n", quotient.result(), calls.result());
  return 0;
}
