// catalog_peer DOMAIN SPACE STEP...: a space's catalog on a DdsLink of its own process (UDP only,
// lease 1500 ms), as another bridge's: the test's own participants would get its samples handed
// over in memory. Each STEP is a comma-separated list of "+NAME" (announce NAME) and "-NAME"
// (withdraw NAME): the first is done at once, each next one on SIGHUP. Exits on SIGTERM.

#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "urs/bridge/dds_link.hpp"
#include "urs/util/cli.hpp"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: catalog_peer DOMAIN SPACE STEP...\n";
    return 2;
  }
  urs::util::block_shutdown_signals(true);  // every thread (Fast DDS's too) inherits the mask
  urs::bridge::DdsOptions options;
  options.domain = static_cast<uint32_t>(std::stoul(argv[1]));
  options.space = argv[2];
  options.bridge = "bridge-" + options.space;
  options.lease = std::chrono::milliseconds(1500);
  options.udp_only = true;
  urs::bridge::DdsLink link(options, [] {}, [](urs::call::Request, urs::call::Responder) {});
  int next = 3;
  auto step = [&] {
    if (next >= argc) return;
    std::istringstream actions(argv[next++]);
    for (std::string action; std::getline(actions, action, ',');) {
      const std::string name = action.substr(1);
      if (action[0] == '-') {
        link.withdraw(name);
      } else {
        urs::bridge::ServiceEntry entry;
        entry.name = name;
        entry.interface_name = "URS.Diagnostic";
        entry.descriptor_set = "a description";
        link.announce(entry);
      }
      std::cout << action << std::endl;
    }
  };
  step();
  urs::util::wait_for_shutdown(step);
  return 0;
}
