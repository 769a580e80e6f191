// AgentHost: decoding, validation, worker-pool dispatch and encoding of outcomes.

#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>

#include "Diagnostic.pb.h"
#include "sam_config.hpp"
#include "urs/agent/agent.hpp"
#include "urs/agent/camus.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/util/cli.hpp"

namespace urs::agent {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

class RecordingSink : public EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    std::lock_guard<std::mutex> lock(mutex);
    topics.push_back(topic);
    types.push_back(event.GetTypeName());
    return call::Reply::success({});
  }
  std::mutex mutex;
  std::vector<std::string> topics;
  std::vector<std::string> types;
};

// Calls dispatch() and waits for the Responder to be answered.
class HostTest : public ::testing::Test {
 protected:
  HostTest() : host_(2, sink_) {
    host_.add({"diag", std::make_shared<diagnostic::DiagnosticAgent>(), {{"room", "lab"}}, 1500});
    host_.start();
  }

  call::Reply call(const std::string& service, const std::string& op, const std::string& payload,
                   uint32_t deadline_ms = 0) {
    call::Request request;
    request.service = service;
    request.operation = op;
    request.payload = payload;
    if (deadline_ms != 0) request.deadline = call::Request::Clock::now() + std::chrono::milliseconds(deadline_ms);
    request.caller = {"lab", "tester", "client"};
    auto promise = std::make_shared<std::promise<call::Reply>>();
    auto future = promise->get_future();
    host_.dispatch(std::move(request),
                   call::Responder::from_callback([promise](call::Reply r) { promise->set_value(r); }));
    if (future.wait_for(5s) != std::future_status::ready)
      return call::Reply::error(call::Status::INTERNAL, "no answer");
    return future.get();
  }

  RecordingSink sink_;
  AgentHost host_;
};

TEST_F(HostTest, CallsTheAgentAndEncodesTheReply) {
  URS::Diagnostic_add_Request request;
  request.set_a(2);
  request.set_b(40);
  auto result = call("diag", "add", request.SerializeAsString());
  ASSERT_TRUE(result.ok()) << result.message;
  URS::Diagnostic_add_Reply reply;
  ASSERT_TRUE(reply.ParseFromString(result.payload));
  EXPECT_EQ(reply.result(), 42);
}

TEST_F(HostTest, UnknownServiceAndOperationAreNamed) {
  auto result = call("nope", "add", "");
  EXPECT_EQ(result.status, call::Status::UNKNOWN_SERVICE);
  EXPECT_THAT(result.message, HasSubstr("'nope'"));
  result = call("diag", "explode", "");
  EXPECT_EQ(result.status, call::Status::UNKNOWN_OPERATION);
  EXPECT_EQ(result.message, "interface URS.Diagnostic has no operation 'explode'");
}

TEST_F(HostTest, UnparsablePayloadIsBadArguments) {
  auto result = call("diag", "add", std::string("\xff\xff\xff", 3));
  EXPECT_EQ(result.status, call::Status::BAD_ARGUMENTS);
  EXPECT_THAT(result.message, HasSubstr("URS.Diagnostic_add_Request"));
}

TEST_F(HostTest, DeclaredExceptionTravelsTyped) {
  URS::Diagnostic_fail_Request request;
  request.set_reason("battery low");
  request.set_code(7);
  auto result = call("diag", "fail", request.SerializeAsString());
  ASSERT_EQ(result.status, call::Status::USER_EXCEPTION);
  EXPECT_EQ(result.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(result.payload));
  EXPECT_EQ(failure.reason(), "battery low");
  EXPECT_EQ(failure.code(), 7);
}

TEST_F(HostTest, ASlowCallDoesNotBlockAnother) {
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(800);
  auto slow = std::async(std::launch::async, [&] { return call("diag", "sleep", sleep.SerializeAsString()); });
  URS::Diagnostic_echo_Request echo;
  echo.set_text("quick");
  auto quick = call("diag", "echo", echo.SerializeAsString());
  EXPECT_TRUE(quick.ok());
  EXPECT_EQ(slow.wait_for(0s), std::future_status::timeout) << "echo was answered only after sleep finished";
  EXPECT_TRUE(slow.get().ok());
}

TEST_F(HostTest, ASleepLongerThanTheCallersDeadlineEndsAtTheDeadline) {
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(60000);  // far beyond call()'s own 5 s wait: only the deadline can end it in time
  const auto result = call("diag", "sleep", sleep.SerializeAsString(), 100);
  EXPECT_EQ(result.status, call::Status::DEADLINE_EXCEEDED) << result.message;
}

TEST_F(HostTest, AgentEventsGoToTheSink) {
  URS::Diagnostic_notify_Request request;
  request.set_topic("lab/door");
  request.set_text("opened");
  auto result = call("diag", "notify", request.SerializeAsString());
  ASSERT_TRUE(result.ok()) << result.message;
  std::lock_guard<std::mutex> lock(sink_.mutex);
  ASSERT_EQ(sink_.topics.size(), 1u);
  EXPECT_EQ(sink_.topics[0], "lab/door");
  EXPECT_EQ(sink_.types[0], "URS.Diagnostic_notify_Request");
}

TEST_F(HostTest, BlobBytesFollowThePattern) {
  for (uint32_t size : {0u, 1u, 250u, 251u, 252u, 1000u, 921600u}) {
    URS::Diagnostic_blob_Request request;
    request.set_size(size);
    auto result = call("diag", "blob", request.SerializeAsString());
    ASSERT_TRUE(result.ok()) << result.message;
    URS::Diagnostic_blob_Reply reply;
    ASSERT_TRUE(reply.ParseFromString(result.payload));
    ASSERT_EQ(reply.result().size(), size);
    for (uint32_t i = 0; i < size; ++i) {
      ASSERT_EQ(static_cast<unsigned char>(reply.result()[i]), i % 251) << "size " << size << " byte " << i;
    }
  }
}

TEST_F(HostTest, OversizedBlobIsRefusedNotAllocated) {
  URS::Diagnostic_blob_Request request;
  request.set_size(1u << 30);
  auto result = call("diag", "blob", request.SerializeAsString());
  EXPECT_EQ(result.status, call::Status::BAD_ARGUMENTS);
  EXPECT_THAT(result.message, HasSubstr("over the limit"));
}

TEST_F(HostTest, RegistrationCarriesInterfaceAndItsDescription) {
  auto reg = registration(*host_.find("diag"));
  EXPECT_EQ(reg.service().name(), "diag");
  EXPECT_EQ(reg.service().interface(), "URS.Diagnostic");
  EXPECT_EQ(reg.service().deadline_ms(), 1500u);
  EXPECT_EQ(reg.service().properties().at("room"), "lab");
  google::protobuf::FileDescriptorSet set;
  ASSERT_TRUE(set.ParseFromString(reg.descriptor_set()));
  bool found = false;
  for (const auto& file : set.file()) {
    for (const auto& service : file.service()) found = found || service.name() == "Diagnostic";
  }
  EXPECT_TRUE(found);
}

// Records what the host tells the agent about each call.
class ContextProbe : public ServiceAgent {
 public:
  const google::protobuf::ServiceDescriptor& interface() const override {
    return *URS::Diagnostic_add_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  }
  Outcome invoke(const google::protobuf::MethodDescriptor&, const google::protobuf::Message&,
                 google::protobuf::Message&, const CallContext& ctx) override {
    service = ctx.service;
    caller = ctx.caller;
    deadline = ctx.deadline;
    return Outcome::ok();
  }
  std::string service;
  call::Identity caller;
  call::Request::Clock::time_point deadline;
};

TEST_F(HostTest, TheAgentSeesTheCallerAndDeadlineTheAdapterGave) {
  auto probe = std::make_shared<ContextProbe>();
  host_.add({"probe", probe, {}, 0});
  const auto before = call::Request::Clock::now();
  ASSERT_EQ(call("probe", "add", "", 2000).status, call::Status::OK);
  EXPECT_EQ(probe->service, "probe");
  EXPECT_EQ(probe->caller.space, "lab");
  EXPECT_EQ(probe->caller.name, "tester");
  EXPECT_EQ(probe->caller.role, "client");
  EXPECT_GE(probe->deadline, before + 2000ms);
  EXPECT_LE(probe->deadline, call::Request::Clock::now() + 2000ms);
}

TEST_F(HostTest, AOnewayCallGetsNoReply) {
  auto probe = std::make_shared<ContextProbe>();
  host_.add({"probe", probe, {}, 0});
  call::Request request;
  request.service = "probe";
  request.operation = "add";
  request.oneway = true;
  auto replied = std::make_shared<std::promise<call::Reply>>();
  auto reply = replied->get_future();
  auto dropped = std::make_shared<std::promise<void>>();
  auto done = dropped->get_future();
  // The responder is destroyed unanswered once the call ran: its callback then sees INTERNAL
  // ("dropped"), never the agent's OK.
  host_.dispatch(std::move(request), call::Responder::from_callback([replied, dropped](call::Reply r) {
                   replied->set_value(r);
                   dropped->set_value();
                 }));
  ASSERT_EQ(done.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(reply.get().status, call::Status::INTERNAL);
  EXPECT_EQ(probe->service, "probe");
}

TEST_F(HostTest, InlineOperationsAreAnsweredOnTheReceivingThreadOthersOnAWorker) {
  auto answered_on = [&](const std::string& op, const std::string& payload) {
    call::Request request;
    request.service = "diag";
    request.operation = op;
    request.payload = payload;
    auto thread = std::make_shared<std::promise<std::thread::id>>();
    auto answered = thread->get_future();
    host_.dispatch(std::move(request), call::Responder::from_callback([thread](call::Reply r) {
                     EXPECT_TRUE(r.ok()) << r.message;
                     thread->set_value(std::this_thread::get_id());
                   }));
    EXPECT_EQ(answered.wait_for(5s), std::future_status::ready);
    return answered.get();
  };
  URS::Diagnostic_echo_Request echo;
  echo.set_text("inline");
  EXPECT_EQ(answered_on("echo", echo.SerializeAsString()), std::this_thread::get_id());
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(1);
  EXPECT_NE(answered_on("sleep", sleep.SerializeAsString()), std::this_thread::get_id())
      << "sleep blocks: it must run on a worker";
}

// Takes every call unparsed and answers it later from a thread of its own, echoing the payload.
class PassThroughAgent : public ServiceAgent {
 public:
  const google::protobuf::ServiceDescriptor& interface() const override {
    return *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  }
  Outcome invoke(const google::protobuf::MethodDescriptor&, const google::protobuf::Message&,
                 google::protobuf::Message&, const CallContext&) override {
    ++invoked;
    return Outcome::ok();
  }
  bool forward(const google::protobuf::MethodDescriptor& method, call::Request& request,
               call::Responder& responder) override {
    if (!take) return false;
    operation = method.name();
    caller = request.caller.name;
    answering = std::thread([payload = std::move(request.payload), responder = std::move(responder)]() mutable {
      responder.reply(call::Reply::success(std::move(payload)));
    });
    return true;
  }
  ~PassThroughAgent() override {
    if (answering.joinable()) answering.join();
  }
  bool take = true;
  int invoked = 0;
  std::string operation;
  std::string caller;
  std::thread answering;
};

TEST_F(HostTest, AForwardingAgentTakesTheCallUnparsedAndAnswersLater) {
  auto agent = std::make_shared<PassThroughAgent>();
  host_.add({"relay", agent, {}, 0});
  const std::string not_a_message("\xff\xff\xff", 3);  // no valid echo request: nobody parsed it
  const auto result = call("relay", "echo", not_a_message);
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_EQ(result.payload, not_a_message);
  EXPECT_EQ(agent->operation, "echo");
  EXPECT_EQ(agent->caller, "tester");
  EXPECT_EQ(agent->invoked, 0);
}

TEST_F(HostTest, AnAgentThatDoesNotForwardACallIsRunAsUsual) {
  auto agent = std::make_shared<PassThroughAgent>();
  agent->take = false;
  host_.add({"relay", agent, {}, 0});
  EXPECT_EQ(call("relay", "echo", std::string("\xff\xff\xff", 3)).status, call::Status::BAD_ARGUMENTS);
  URS::Diagnostic_echo_Request echo;
  echo.set_text("parsed");
  EXPECT_TRUE(call("relay", "echo", echo.SerializeAsString()).ok());
  EXPECT_EQ(agent->invoked, 1);
}

TEST(AgentHostConfig, DuplicateServiceNamesAreRefused) {
  RecordingSink sink;
  AgentHost host(1, sink);
  host.add({"diag", std::make_shared<diagnostic::DiagnosticAgent>(), {}, 0});
  EXPECT_THROW(host.add({"diag", std::make_shared<diagnostic::DiagnosticAgent>(), {}, 0}), std::invalid_argument);
}

TEST(AgentHostStop, QueuedCallsAreAnsweredWhenTheHostStops) {
  RecordingSink sink;
  AgentHost host(1, sink);
  host.add({"diag", std::make_shared<diagnostic::DiagnosticAgent>(), {}, 0});
  host.start();
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(300);
  call::Request request;
  request.service = "diag";
  request.operation = "sleep";
  request.payload = sleep.SerializeAsString();
  std::mutex mutex;
  std::vector<call::Status> answers;
  for (int i = 0; i < 3; ++i) {
    host.dispatch(request, call::Responder::from_callback([&](call::Reply r) {
                    std::lock_guard<std::mutex> lock(mutex);
                    answers.push_back(r.status);
                  }));
  }
  host.stop();
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(answers.size(), 3u) << "a queued call was dropped without an answer";
  // One worker: at most the first call started before stop(); the queued ones are refused.
  EXPECT_GE(std::count(answers.begin(), answers.end(), call::Status::UNAVAILABLE), 2);
  EXPECT_EQ(std::count(answers.begin(), answers.end(), call::Status::UNAVAILABLE) +
                std::count(answers.begin(), answers.end(), call::Status::OK),
            3);
}

// Blocks every call until opened; says when a call entered.
class GateAgent : public ServiceAgent {
 public:
  const google::protobuf::ServiceDescriptor& interface() const override {
    return *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  }
  Outcome invoke(const google::protobuf::MethodDescriptor&, const google::protobuf::Message&,
                 google::protobuf::Message&, const CallContext&) override {
    std::unique_lock<std::mutex> lock(mutex);
    ++entered;
    changed.notify_all();
    changed.wait(lock, [&] { return open; });
    return Outcome::ok();
  }
  void open_gate() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      open = true;
    }
    changed.notify_all();
  }
  std::mutex mutex;
  std::condition_variable changed;
  int entered = 0;
  bool open = false;
};

TEST(AgentHostQueue, ACallBeyondTheConfiguredQueueIsRefusedNamingTheLimit) {
  std::mutex mutex;  // before the host: its answers may come as it stops
  std::condition_variable answered;
  std::vector<call::Reply> answers;
  RecordingSink sink;
  AgentHost host(HostOptions{1, 2, "workers.queue"}, sink);
  auto gate = std::make_shared<GateAgent>();
  // Whatever happens below, the gate opens before the host stops (which waits for its worker).
  struct Opener {
    GateAgent& gate;
    ~Opener() { gate.open_gate(); }
  } opener{*gate};
  host.add({"gate", gate, {}, 0});
  host.start();
  URS::Diagnostic_echo_Request echo;
  echo.set_text("x");
  call::Request request;
  request.service = "gate";
  request.operation = "echo";
  request.payload = echo.SerializeAsString();
  auto dispatch = [&] {
    host.dispatch(request, call::Responder::from_callback([&](call::Reply r) {
                    std::lock_guard<std::mutex> lock(mutex);
                    answers.push_back(r);
                    answered.notify_all();
                  }));
  };
  dispatch();  // runs on the one worker, held by the gate
  {
    std::unique_lock<std::mutex> lock(gate->mutex);
    ASSERT_TRUE(gate->changed.wait_for(lock, 5s, [&] { return gate->entered == 1; }));
  }
  dispatch();  // waits (1 of 2)
  dispatch();  // waits (2 of 2)
  dispatch();  // beyond the queue: refused at once, on this thread
  {
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_EQ(answers.size(), 1u);
    EXPECT_EQ(answers[0].status, call::Status::RESOURCE_EXHAUSTED);
    EXPECT_EQ(answers[0].message,
              "gate.echo refused: 2 calls already wait for the host's 1 workers (workers.queue 2); try again later");
  }
  gate->open_gate();
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(answered.wait_for(lock, 5s, [&] { return answers.size() == 4; }));
    EXPECT_EQ(std::count_if(answers.begin(), answers.end(), [](const call::Reply& r) { return r.ok(); }), 3)
        << "the calls within the queue were served";
  }
  host.stop();
}

}  // namespace
}  // namespace urs::agent
