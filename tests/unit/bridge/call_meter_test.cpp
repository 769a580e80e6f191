// core::MeteredAgent on an AgentHost: every call a stand-in takes is recorded once, whether the
// agent it wraps forwards it or the host runs it on a worker, under the stand-in's name with its
// final status; the call's trace is current wherever the wrapped agent hands it on; oneway calls
// are handed on unrecorded.

#include "urs/bridge/core/call_meter.hpp"

#include <gtest/gtest.h>

#include <future>
#include <mutex>
#include <vector>

#include "Diagnostic.pb.h"
#include "urs/util/trace.hpp"

namespace urs::bridge::core {
namespace {

using namespace std::chrono_literals;

struct Recorded {
  std::string service;
  std::string operation;
  call::Status status;
};

class Recorder : public call::CallRecorder {
 public:
  void record(const std::string& service, const std::string& operation, call::Status status,
              std::chrono::steady_clock::duration) noexcept override {
    std::lock_guard lock(mutex_);
    calls_.push_back({service, operation, status});
  }
  void record_unchecked(const std::string& service, const std::string& operation, call::Status status,
                        std::chrono::steady_clock::duration elapsed) noexcept override {
    record(service, operation, status, elapsed);
  }
  std::vector<Recorded> calls() {
    std::lock_guard lock(mutex_);
    return calls_;
  }

 private:
  std::mutex mutex_;
  std::vector<Recorded> calls_;
};

// The agent a stand-in's source would serve: forwards (answering at once) or leaves the call to
// the host, and notes the trace current where it handles it.
class Inner : public agent::ServiceAgent {
 public:
  const google::protobuf::ServiceDescriptor& interface() const override {
    return *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  }
  agent::Outcome invoke(const google::protobuf::MethodDescriptor&, const google::protobuf::Message&,
                        google::protobuf::Message&, const agent::CallContext&) override {
    note_trace();
    return agent::Outcome::error(call::Status::UNAVAILABLE, "invoked");
  }
  bool forward(const google::protobuf::MethodDescriptor&, call::Request&, call::Responder& responder) override {
    if (!forwards) return false;
    note_trace();
    responder.reply(call::Reply::success({}));
    return true;
  }
  void note_trace() {
    std::lock_guard lock(mutex);
    const util::TraceContext* current = util::current_trace();
    traces.push_back(current ? current->trace_id_hex() : "");
  }

  bool forwards = true;
  std::mutex mutex;
  std::vector<std::string> traces;
};

class Metering : public ::testing::Test {
 protected:
  Metering() : host_(1, events_) {
    host_.add({"jp/diag", std::make_shared<MeteredAgent>(inner_, "dds -> camus", "jp/diag", &recorder_), {}, 0});
    host_.start();
  }
  ~Metering() override { host_.stop(); }

  call::Reply dispatch(const std::string& operation, bool oneway = false) {
    call::Request request;
    request.service = "jp/diag";
    request.operation = operation;
    request.oneway = oneway;
    request.traceparent = trace_.traceparent();
    std::promise<call::Reply> answered;
    auto answer = answered.get_future();
    call::Responder responder =
        oneway ? call::Responder()
               : call::Responder::from_callback([&](call::Reply reply) { answered.set_value(std::move(reply)); });
    host_.dispatch(std::move(request), std::move(responder));
    if (oneway) return call::Reply::success({});
    EXPECT_EQ(answer.wait_for(2s), std::future_status::ready);
    return answer.get();
  }

  const util::TraceContext trace_ = util::TraceContext::start();
  Recorder recorder_;
  std::shared_ptr<Inner> inner_ = std::make_shared<Inner>();
  agent::DiscardingEventSink events_;
  agent::AgentHost host_;
};

TEST_F(Metering, AForwardedCallIsRecordedOnceUnderItsStandInWithItsTraceCurrent) {
  EXPECT_EQ(dispatch("echo").status, call::Status::OK);
  const auto calls = recorder_.calls();
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0].service, "jp/diag");
  EXPECT_EQ(calls[0].operation, "echo");
  EXPECT_EQ(calls[0].status, call::Status::OK);
  EXPECT_EQ(inner_->traces, std::vector<std::string>{trace_.trace_id_hex()});
}

TEST_F(Metering, ACallLeftToTheHostIsRecordedOnceFromItsWorkerWithItsTraceCurrent) {
  inner_->forwards = false;
  EXPECT_EQ(dispatch("echo").status, call::Status::UNAVAILABLE);
  const auto calls = recorder_.calls();
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0].status, call::Status::UNAVAILABLE);
  EXPECT_EQ(inner_->traces, std::vector<std::string>{trace_.trace_id_hex()});
}

TEST_F(Metering, AOnewayCallIsHandedOnUnrecorded) {
  dispatch("echo", true);
  EXPECT_TRUE(recorder_.calls().empty());
  EXPECT_EQ(inner_->traces.size(), 1u);
}

}  // namespace
}  // namespace urs::bridge::core
