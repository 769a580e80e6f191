// urs-dds-echo DOMAIN READY_FILE [PKI_FOLDER]: the far end of urs-bench's direct Fast DDS
// request/reply rows, in a process of its own so that a row measures UDP between processes (two
// participants of one process would hand samples over in memory). Space "dds-b": answers every call
// at once with its payload, and "blob" with a 921,600-byte reply. With PKI_FOLDER (deploy/pki.sh's
// layout, a member "dds-b") it joins with DDS-Security. Writes READY_FILE once joined; exits on
// SIGTERM.

#include <iostream>
#include <string>

#include "Diagnostic.pb.h"
#include "urs/federation/dds_link.hpp"
#include "urs/util/cli.hpp"

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::cerr << "usage: urs-dds-echo DOMAIN READY_FILE [PKI_FOLDER]\n";
    return 2;
  }
  urs::util::block_shutdown_signals();  // every thread (Fast DDS's too) inherits the mask

  URS::Diagnostic_blob_Reply big;
  big.set_result(std::string(921600, 'x'));
  const std::string big_reply = big.SerializeAsString();
  urs::federation::DdsOptions options;
  options.domain = static_cast<uint32_t>(std::stoul(argv[1]));
  options.space = "dds-b";
  options.bridge = "b";
  options.udp_only = true;
  if (argc == 4) options.security = urs::federation::security_from_folder(argv[3], options.space);
  // Answered inside the handler, on the DDS listener thread: the link writes the reply from its
  // replier thread (a reply written on the listener thread could deadlock Fast DDS 2.9).
  urs::federation::DdsLink link(
      options, [] {},
      [&](urs::call::Request request, urs::call::Responder responder) {
        responder.reply(urs::call::Reply::success(request.operation == "blob" ? big_reply : request.payload));
      });
  urs::util::write_file_atomically(argv[2], "ready\n");
  urs::util::wait_for_shutdown();
  return 0;
}
