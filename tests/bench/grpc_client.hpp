#pragma once
// urs-bench's side of the gRPC rows: urs-grpc-echo started in a process of its own, and its clients
// through the synchronous (blocking stub) and the asynchronous (callback) APIs.

#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

#include "bench_echo.grpc.pb.h"
#include "process.hpp"

namespace urs::bench {

// A client of its own channel (no subchannel shared with another client of the same target), as
// a separate program would have.
class GrpcClient {
 public:
  explicit GrpcClient(uint16_t port) {
    grpc::ChannelArguments arguments;
    arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
    channel_ =
        grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials(), arguments);
    stub_ = Echo::NewStub(channel_);
  }

  // One call through the blocking stub; `request` asks for an echo or for reply_size bytes.
  void call(const EchoMessage& request) {
    grpc::ClientContext context;
    EchoMessage reply;
    check(stub_->Echo(&context, request, &reply));
  }

  // One call through the callback API, waited for (the latency of the asynchronous path).
  void call_async(const EchoMessage& request) {
    grpc::ClientContext context;
    EchoMessage reply;
    std::mutex mutex;
    std::condition_variable done;
    bool finished = false;
    grpc::Status status;
    stub_->async()->Echo(&context, &request, &reply, [&](grpc::Status s) {
      std::lock_guard lock(mutex);
      status = std::move(s);
      finished = true;
      done.notify_one();
    });
    std::unique_lock lock(mutex);
    done.wait(lock, [&] { return finished; });
    check(status);
  }

  // `count` calls through the callback API, each issued from the completion of the one before
  // (no thread of the caller's waits between them); returns once the last has completed.
  void chain_async(const EchoMessage& request, int count) {
    struct Chain {
      GrpcClient* client;
      const EchoMessage* request;
      int remaining;
      std::unique_ptr<grpc::ClientContext> context;
      EchoMessage reply;
      std::mutex mutex;
      std::condition_variable done;
      bool finished = false;
      grpc::Status failure;
      void next() {
        context = std::make_unique<grpc::ClientContext>();
        client->stub_->async()->Echo(context.get(), request, &reply, [this](grpc::Status status) {
          if (status.ok() && --remaining > 0) {
            next();
            return;
          }
          std::lock_guard lock(mutex);
          failure = status;
          finished = true;
          done.notify_one();
        });
      }
    } chain{this, &request, count, nullptr, {}, {}, {}, false, {}};
    chain.next();
    std::unique_lock lock(chain.mutex);
    chain.done.wait(lock, [&] { return chain.finished; });
    check(chain.failure);
  }

 private:
  static void check(const grpc::Status& status) {
    if (!status.ok()) throw std::runtime_error("gRPC call failed: " + status.error_message());
  }
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<Echo::Stub> stub_;
};

// urs-grpc-echo running, with the ports of its synchronous and callback servers.
class GrpcEchoProcess {
 public:
  GrpcEchoProcess(std::vector<std::string> argv, const std::string& dir) {
    const std::string ready = dir + "/grpc-echo.ready";
    argv.push_back(ready);
    process_ = std::make_unique<test::Process>(argv, dir + "/grpc-echo.log");
    if (!test::wait_until([&] { return std::filesystem::exists(ready) && !test::read_text(ready).empty(); },
                          std::chrono::seconds(30))) {
      throw std::runtime_error("urs-grpc-echo did not start: " + process_->log());
    }
    std::istringstream ports(test::read_text(ready));
    ports >> sync_port_ >> callback_port_;
  }
  uint16_t sync_port() const { return static_cast<uint16_t>(sync_port_); }
  uint16_t callback_port() const { return static_cast<uint16_t>(callback_port_); }

 private:
  std::unique_ptr<test::Process> process_;
  int sync_port_ = 0;
  int callback_port_ = 0;
};

}  // namespace urs::bench
