// urs-grpc-echo READY_FILE: the far end of urs-bench's gRPC rows, in a process of its own as
// urs-camus-server and urs-sam are. Two servers on 127.0.0.1: the synchronous API (a blocking
// handler on gRPC's thread pool) and the callback API (the handler answers from the thread that
// received the call, gRPC's asynchronous server). Writes "SYNC_PORT CALLBACK_PORT" to READY_FILE
// once both listen; exits on SIGTERM.

#include <grpcpp/grpcpp.h>

#include <iostream>
#include <memory>
#include <string>

#include "bench_echo.grpc.pb.h"
#include "urs/util/cli.hpp"

namespace {

void answer(const urs::bench::EchoMessage& request, urs::bench::EchoMessage& reply) {
  if (request.reply_size() > 0) {
    reply.mutable_data()->assign(request.reply_size(), 'x');
  } else {
    reply.set_data(request.data());
  }
}

class SyncEcho final : public urs::bench::Echo::Service {
  grpc::Status Echo(grpc::ServerContext*, const urs::bench::EchoMessage* request,
                    urs::bench::EchoMessage* reply) override {
    answer(*request, *reply);
    return grpc::Status::OK;
  }
};

class CallbackEcho final : public urs::bench::Echo::CallbackService {
  grpc::ServerUnaryReactor* Echo(grpc::CallbackServerContext* context, const urs::bench::EchoMessage* request,
                                 urs::bench::EchoMessage* reply) override {
    answer(*request, *reply);
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    reactor->Finish(grpc::Status::OK);
    return reactor;
  }
};

std::unique_ptr<grpc::Server> listen(grpc::Service& service, int& port) {
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  auto server = builder.BuildAndStart();
  if (!server || port == 0) throw std::runtime_error("gRPC server did not start");
  return server;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: urs-grpc-echo READY_FILE\n";
    return 2;
  }
  urs::util::block_shutdown_signals();  // gRPC's threads inherit the mask

  SyncEcho sync_service;
  CallbackEcho callback_service;
  int sync_port = 0;
  int callback_port = 0;
  auto sync_server = listen(sync_service, sync_port);
  auto callback_server = listen(callback_service, callback_port);
  urs::util::write_file_atomically(argv[1], std::to_string(sync_port) + " " + std::to_string(callback_port) + "\n");
  urs::util::wait_for_shutdown();
  sync_server->Shutdown();
  callback_server->Shutdown();
  return 0;
}
