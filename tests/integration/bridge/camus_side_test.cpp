// The bridge seen from the CAMUS side: an RT provider offered by urs-bridge answers Planet clients
// exactly as the native agent of the same interface does (results, errors, exceptions with their
// fields); per-service deadlines, concurrency, a provider dying mid-call or vanishing; an
// interface known only from an IDL file given in the configuration; an RT OutPort feeding events
// and context. All parts are real processes but the test's own Planet client and RTC.

#include <gtest/gtest.h>
#include <signal.h>

#include <future>
#include <iostream>

#include "Diagnostic.pb.h"
#include "bridge_fixture.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/schema/schema.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace gp = google::protobuf;

class BridgeCamusSide : public BridgeSpaceTest {
 protected:
  Observed call(const std::string& service, const std::string& operation, const std::string& payload,
                std::chrono::milliseconds deadline = 5s) {
    const auto r = planet_->call(service, operation, payload, deadline);
    return {r.status, r.payload, r.exception_type, r.message};
  }

  // The same call to the native agent and to the bridged RTC; they must look the same.
  Observed expect_same(const std::string& operation, const gp::Message& request,
                       std::chrono::milliseconds deadline = 5s) {
    return expect_same_bytes(operation, request.SerializeAsString(), deadline);
  }
  Observed expect_same_bytes(const std::string& operation, const std::string& payload,
                             std::chrono::milliseconds deadline = 5s) {
    const Observed native = call("diag", operation, payload, deadline);
    const auto start = Clock::now();
    const Observed bridged = call("rt.Diagnostic0", operation, payload, deadline);
    std::cout << operation << " through the bridge: " << planet::status_name(bridged.status) << " after "
              << std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start).count() << " us ("
              << bridged.message << ")\n";
    EXPECT_EQ(bridged.status, native.status)
        << operation << ": native '" << native.message << "', bridged '" << bridged.message << "'";
    EXPECT_EQ(bridged.payload, native.payload) << operation;
    EXPECT_EQ(bridged.exception_type, native.exception_type) << operation;
    return bridged;
  }

  void start_diagnostic_space() {
    start_manager("m", "labhost", "components:\n  - type: Diagnostic\n");
    start_bridge(diagnostic_rules(1500));
    ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  }
};

TEST_F(BridgeCamusSide, RtProviderAnswersAsTheNativeAgentDoes) {
  start_diagnostic_space();
  if (HasFatalFailure()) return;

  URS::Diagnostic_echo_Request echo;
  echo.set_text("héllo from CAMUS, ünïcode kept");
  EXPECT_EQ(expect_same("echo", echo).status, planet::OK);
  URS::Diagnostic_add_Request add;
  add.set_a(2.5);
  add.set_b(-7.25);
  EXPECT_EQ(expect_same("add", add).status, planet::OK);

  URS::Diagnostic_blob_Request blob;
  blob.set_size(921600);
  const Observed image = expect_same("blob", blob);
  ASSERT_EQ(image.status, planet::OK);
  URS::Diagnostic_blob_Reply bytes;
  ASSERT_TRUE(bytes.ParseFromString(image.payload));
  ASSERT_EQ(bytes.result().size(), 921600u);
  URS::Diagnostic_checksum_Request checksum;
  checksum.set_data(bytes.result());
  const Observed sum = expect_same("checksum", checksum);
  URS::Diagnostic_checksum_Reply sum_reply;
  ASSERT_TRUE(sum_reply.ParseFromString(sum.payload));
  EXPECT_EQ(sum_reply.result(), diagnostic::fnv1a64(bytes.result().data(), bytes.result().size()));

  URS::Diagnostic_fail_Request fail;
  fail.set_reason("motor overheated");
  fail.set_code(-42);
  const Observed raised = expect_same("fail", fail);
  EXPECT_EQ(raised.status, planet::USER_EXCEPTION);
  EXPECT_EQ(raised.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(raised.payload));
  EXPECT_EQ(failure.reason(), "motor overheated");
  EXPECT_EQ(failure.code(), -42);

  URS::Diagnostic_sleep_Request too_long;  // over the agent's limit: refused before it runs
  too_long.set_ms(3'600'000);
  EXPECT_EQ(expect_same("sleep", too_long).status, planet::BAD_ARGUMENTS);
  URS::Diagnostic_sleep_Request slow;
  slow.set_ms(400);
  EXPECT_EQ(expect_same("sleep", slow, 100ms).status, planet::DEADLINE_EXCEEDED);

  EXPECT_EQ(expect_same_bytes("echo", std::string("\xff\xff\xff garbage", 11)).status, planet::BAD_ARGUMENTS);
  EXPECT_EQ(expect_same_bytes("explode", "").status, planet::UNKNOWN_OPERATION);

  // The bridged service keeps answering after all of that.
  EXPECT_EQ(expect_same("echo", echo).status, planet::OK);

  // urs ls names where each service really is.
  EXPECT_NE(listed("diag").find("native"), std::string::npos) << listed("diag");
  EXPECT_NE(listed("rt.Diagnostic0").find("rtc:labhost.host_cxt/Diagnostic0.rtc:diagnostic"), std::string::npos)
      << listed("rt.Diagnostic0");
}

TEST_F(BridgeCamusSide, PerServiceDeadlineBoundsSlowCallsWhichNeverHoldUpOthers) {
  start_diagnostic_space();
  if (HasFatalFailure()) return;
  // The rule bounds calls to 1500 ms, whatever the caller allows.
  URS::Diagnostic_sleep_Request long_sleep;
  long_sleep.set_ms(4000);
  // The bridge's call to the provider timed out (the caller, allowing 20 s, did not give up).
  const Observed bounded = call("rt.Diagnostic0", "sleep", long_sleep.SerializeAsString(), 20s);
  EXPECT_EQ(bounded.status, planet::DEADLINE_EXCEEDED) << bounded.message;
  EXPECT_NE(bounded.message.find("deadline passed: sleep"), std::string::npos) << bounded.message;

  // A slow call in flight; three quick calls answer while it is still running.
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(1200);
  auto slow =
      std::async(std::launch::async, [&] { return call("rt.Diagnostic0", "sleep", sleep.SerializeAsString(), 10s); });
  URS::Diagnostic_echo_Request echo;
  echo.set_text("quick");
  for (int i = 0; i < 3; ++i) EXPECT_EQ(call("rt.Diagnostic0", "echo", echo.SerializeAsString()).status, planet::OK);
  EXPECT_EQ(slow.wait_for(0ms), std::future_status::timeout) << "the echoes waited for the sleep";
  EXPECT_EQ(slow.get().status, planet::OK);
}

TEST_F(BridgeCamusSide, ProviderKilledMidCallIsAClearErrorAndItsServiceIsWithdrawn) {
  start_diagnostic_space();
  if (HasFatalFailure()) return;
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(1400);
  auto pending =
      std::async(std::launch::async, [&] { return call("rt.Diagnostic0", "sleep", sleep.SerializeAsString(), 10s); });
  // The provider's debug log says when the call has reached it.
  ASSERT_TRUE(
      wait_until([&] { return manager("m").log().find("diagnostic: sleep 1400 ms begins") != std::string::npos; }, 10s))
      << manager("m").log();
  manager("m").kill9();
  // Unavailable, not DEADLINE_EXCEEDED: the caller was answered when the provider died rather than
  // left waiting for its deadline.
  const Observed failed = pending.get();
  EXPECT_EQ(failed.status, planet::UNAVAILABLE) << failed.message;
  EXPECT_NE(failed.message.find("provider gone"), std::string::npos) << failed.message;
  // The dead provider's binding is still in the naming service, but its service is withdrawn.
  EXPECT_TRUE(wait_service_gone("rt.Diagnostic0")) << bridge_->log();
  EXPECT_EQ(call("diag", "echo", URS::Diagnostic_echo_Request().SerializeAsString()).status, planet::OK);

  // A new provider appears: the bridge finds it and offers it again.
  start_manager("m2", "labhost", "components:\n  - type: Diagnostic\n");
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  URS::Diagnostic_echo_Request echo;
  echo.set_text("back");
  EXPECT_EQ(call("rt.Diagnostic0", "echo", echo.SerializeAsString()).status, planet::OK);
  // A clean exit unbinds it; the service goes with it.
  manager("m2").signal(SIGTERM);
  EXPECT_EQ(manager("m2").wait(10s), 0);
  EXPECT_TRUE(wait_service_gone("rt.Diagnostic0")) << bridge_->log();
}

// ---- an interface the bridge was not built with ----------------------------------------------

// Lab::Thermostat implemented from its run-time description: reflection only, no generated class.
class Thermostat : public agent::ServiceAgent {
 public:
  explicit Thermostat(const gp::ServiceDescriptor& interface) : interface_(interface) {}
  const gp::ServiceDescriptor& interface() const override { return interface_; }
  agent::Outcome invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                        const agent::CallContext&) override {
    const auto* in = request.GetReflection();
    const auto* out = reply.GetReflection();
    if (method.name() == "set") {
      const double celsius = in->GetDouble(request, method.input_type()->FindFieldByName("celsius"));
      if (celsius < 5 || celsius > 35) {
        const gp::Descriptor* type = interface_.file()->pool()->FindMessageTypeByName("Lab.OutOfRange");
        std::shared_ptr<gp::Message> raised(factory_.GetPrototype(type)->New());
        raised->GetReflection()->SetDouble(raised.get(), type->FindFieldByName("celsius"), celsius);
        raised->GetReflection()->SetString(raised.get(), type->FindFieldByName("reason"), "outside 5..35");
        return agent::Outcome::raise(raised, "OutOfRange");
      }
      target_ = celsius;
      return agent::Outcome::ok();
    }
    if (method.name() == "target") {
      out->SetDouble(&reply, method.output_type()->FindFieldByName("result"), target_);
      return agent::Outcome::ok();
    }
    const std::string room = in->GetString(request, method.input_type()->FindFieldByName("room"));
    out->SetString(&reply, method.output_type()->FindFieldByName("result"), room + " at " + std::to_string(target_));
    out->SetInt32(&reply, method.output_type()->FindFieldByName("readings"), 3);
    return agent::Outcome::ok();
  }

 private:
  const gp::ServiceDescriptor& interface_;
  gp::DynamicMessageFactory factory_;
  double target_ = 20;
};

TEST_F(BridgeCamusSide, AnInterfaceKnownOnlyFromAnIdlFileInTheConfiguration) {
  const std::string idl = std::string(URS_TEST_IDL_DIR) + "/Thermostat.idl";
  // The provider: an RTC of this process whose agent is built from the same file at run time.
  const schema::IdlLoad loaded = schema::load_idl(idl);
  ASSERT_TRUE(loaded.ok()) << loaded.error;
  schema::SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(loaded.descriptor_set), "");
  const gp::ServiceDescriptor* interface = pool.find_service("Lab.Thermostat");
  ASSERT_NE(interface, nullptr);
  rtc::Manager host(test_orb(), *client_, {"lab", "testhost", 10});
  host.create({"Thermostat", "", 0, false, {}, {}}, [&](const YAML::Node&, const rtc::ComponentEnv&) {
    corba_agent::AgentComponentConfig settings;
    settings.type_name = "Thermostat";
    return std::make_unique<corba_agent::AgentComponent>(settings, std::make_shared<Thermostat>(*interface));
  });

  start_bridge(
      "name: bridge-test\n"
      "idl: [" +
      idl +
      "]\n"
      "rt_to_camus:\n"
      "  poll_ms: 100\n"
      "  providers:\n"
      "    - match: \"*/Thermostat*.rtc\"\n"
      "      name: lab.thermostat\n");
  ASSERT_TRUE(wait_for_service("lab.thermostat")) << bridge_->log();
  EXPECT_NE(listed("lab.thermostat").find("Lab.Thermostat"), std::string::npos);

  // The CLI knows nothing of it either: it asks the registry for the description.
  auto r = urs({"call", "lab.thermostat", "set", R"({"celsius": 22.5})"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  r = urs({"call", "lab.thermostat", "target"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("22.5"), std::string::npos) << r.out;
  r = urs({"call", "lab.thermostat", "describe", R"({"room": "kitchen"})"});
  EXPECT_NE(r.out.find("kitchen at 22.5"), std::string::npos) << r.out << r.err;
  EXPECT_NE(r.out.find("\"readings\":3"), std::string::npos) << r.out;
  r = urs({"call", "lab.thermostat", "set", R"({"celsius": 99})"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("Lab.OutOfRange"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("outside 5..35"), std::string::npos) << r.err;
  r = urs({"call", "lab.thermostat", "set", R"({"celsius": "warm"})"});
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;  // a wrong argument type is the caller's mistake
  host.shutdown();
  EXPECT_TRUE(wait_service_gone("lab.thermostat")) << bridge_->log();
}

// ---- data ports ------------------------------------------------------------------------------

TEST_F(BridgeCamusSide, AnRtOutPortFeedsEventsAndContext) {
  start_manager("m", "labhost", "components:\n  - type: Counter\n    activate: true\n");
  start_bridge(
      "name: bridge-test\n"
      "idl: [" +
      std::string(URS_RTC_IDL_DIR) +
      "/BasicDataType.idl]\n"
      "rt_to_camus: {poll_ms: 100}\n"
      "data_to_camus:\n"
      "  - match: \"*/Counter0.rtc\"\n"
      "    port: count\n"
      "    type: RTC.TimedLong\n"
      "    topic: counter/count\n"
      "    context: counter.count\n");
  // Shared with the handler, which runs on the client's thread until the client is stopped.
  struct Received {
    std::mutex mutex;
    std::vector<planet::Event> events;
  };
  auto received = std::make_shared<Received>();
  planet_->subscribe("counter/#", [received](const planet::Event& event) {
    std::lock_guard lock(received->mutex);
    received->events.push_back(event);
  });
  ASSERT_TRUE(wait_until(
      [&] {
        std::lock_guard lock(received->mutex);
        return received->events.size() >= 20;
      },
      15s))
      << bridge_->log();
  // Values arrive in order, each a TimedLong as the Counter wrote it (data +1 per execution).
  const schema::IdlLoad types = schema::load_idl(std::string(URS_RTC_IDL_DIR) + "/BasicDataType.idl");
  ASSERT_TRUE(types.ok()) << types.error;
  schema::SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(types.descriptor_set), "");
  const gp::Descriptor* timed_long = pool.find_message("RTC.TimedLong");
  ASSERT_NE(timed_long, nullptr);
  std::vector<planet::Event> events;
  {
    std::lock_guard lock(received->mutex);
    events = received->events;
  }
  int64_t previous = -1;
  for (const auto& event : events) {
    EXPECT_EQ(event.content_type(), "RTC.TimedLong");
    auto value = pool.new_message(*timed_long);
    ASSERT_TRUE(value->ParseFromString(event.payload()));
    const int64_t data = value->GetReflection()->GetInt32(*value, timed_long->FindFieldByName("data"));
    EXPECT_GT(data, previous);
    previous = data;
  }
  const auto r = urs({"context", "get", "counter.count"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"data\""), std::string::npos) << r.out;
  // The source is who the server authenticated (an open server: anonymous); the bridge's own name
  // is what it declared, kept as the origin.
  EXPECT_NE(r.out.find("\"source\":\"anonymous\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"origin\":\"bridge-test\""), std::string::npos) << r.out;
}

}  // namespace
}  // namespace urs::test
