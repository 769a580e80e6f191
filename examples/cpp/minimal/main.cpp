// greeter-agent: hosts the example's Greeter agent in a CAMUS space, as urs-sam hosts its agents:
// it registers the service with the server and serves calls until SIGINT or SIGTERM.
//   greeter-agent --space NAME [--server HOST:PORT] [--name SERVICE] [--token-file FILE]
// Exit codes: 0 after a signal; 2 bad arguments.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "greeter_agent.hpp"
#include "urs/agent/agent.hpp"
#include "urs/agent/camus.hpp"
#include "urs/agent/client_sink.hpp"
#include "urs/planet/client.hpp"
#include "urs/util/cli.hpp"

int main(int argc, char** argv) {
  std::map<std::string, std::string> args = {{"--server", "127.0.0.1:7600"}, {"--name", "greeter"}};
  for (int i = 1; i + 1 < argc; i += 2) args[argv[i]] = argv[i + 1];
  if (argc % 2 == 0 || args.count("--space") == 0) {
    std::fprintf(stderr, "usage: %s --space NAME [--server HOST:PORT] [--name SERVICE] [--token-file FILE]\n", argv[0]);
    return 2;
  }

  urs::util::block_shutdown_signals();
  urs::planet::ClientOptions options;
  try {
    urs::util::init_logging("greeter-agent", "info");
    const auto endpoint = urs::util::parse_endpoint(args["--server"], "--server");
    options.host = endpoint.host;
    options.port = endpoint.port;
    options.token = urs::util::read_token_file(args["--token-file"]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "greeter-agent: %s\n", e.what());
    return 2;
  }
  options.peer_name = "greeter@" + urs::util::host_name();
  options.role = urs::planet::SAM;

  urs::planet::Client client(options);
  urs::agent::ClientEventSink events(client);
  urs::agent::AgentHost host(2, events);
  host.add({args["--name"], std::make_shared<example::GreeterAgent>(), {}, 0});
  urs::agent::serve_requests(client, host);
  for (const auto& service : host.services()) {
    client.register_service(urs::agent::registration(service), [name = service.name](urs::planet::CallResult result) {
      if (result.ok())
        spdlog::info("registered service {}", name);
      else
        spdlog::error("registering {} failed: {}", name, result.message);
    });
  }
  client.start();
  host.start();
  const int signal_number = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: stopping", signal_number);
  host.stop();
  client.stop();
  return 0;
}
