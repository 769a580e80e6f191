// urs-dds-echo DOMAIN READY_FILE: the far end of urs-bench's direct Fast DDS request/reply row, in
// a process of its own so that the row measures UDP between processes (two participants of one
// process would hand samples over in memory). Space "dds-b": answers every call at once with its
// payload, and "blob" with a 921,600-byte reply. Writes READY_FILE once joined; exits on SIGTERM.

#include <signal.h>

#include <fstream>
#include <iostream>
#include <string>

#include "Diagnostic.pb.h"
#include "urs/bridge/dds_link.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: urs-dds-echo DOMAIN READY_FILE\n";
    return 2;
  }
  // Every thread (Fast DDS's too) inherits the mask; the main thread takes the signal with sigwait.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);

  URS::Diagnostic_blob_Reply big;
  big.set_result(std::string(921600, 'x'));
  const std::string big_reply = big.SerializeAsString();
  urs::bridge::DdsOptions options;
  options.domain = static_cast<uint32_t>(std::stoul(argv[1]));
  options.space = "dds-b";
  options.bridge = "b";
  options.udp_only = true;
  // Answered inside the handler, on the DDS listener thread: the link writes the reply from its
  // replier thread (a reply written on the listener thread could deadlock Fast DDS 2.9).
  urs::bridge::DdsLink link(options, [] {}, [&](urs::call::Request request, urs::call::Responder responder) {
    responder.reply(urs::call::Reply::success(request.operation == "blob" ? big_reply : request.payload));
  });
  std::ofstream(argv[2]) << "ready\n";
  int signal = 0;
  sigwait(&stop, &signal);
  return 0;
}
