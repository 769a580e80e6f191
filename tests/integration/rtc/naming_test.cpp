// Naming: components bound as <host>.host_cxt/<Type><N>.rtc in a real omniNames; replicas never
// overwrite each other; stale bindings are repaired; clean exits unbind.

#include <gtest/gtest.h>
#include <signal.h>

#include "rt_space.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kConfig = "components:\n  - type: Diagnostic\n";

class Naming : public RtSpaceTest {
 protected:
  std::string instance_of(const std::string& path) {
    auto rtc = resolve<RTC::RTObject>(path);
    RTC::ComponentProfile_var profile = rtc->get_component_profile();
    return profile->instance_name.in();
  }
};

TEST_F(Naming, ManagersOnTwoHostsLeaveTwoBindings) {
  EXPECT_EQ(start_manager("a", "hostA", kConfig), "hostA.host_cxt/Diagnostic0.rtc\n");
  EXPECT_EQ(start_manager("b", "hostB", kConfig), "hostB.host_cxt/Diagnostic0.rtc\n");
  CORBA::Object_var a = client_->resolve("hostA.host_cxt/Diagnostic0.rtc");
  CORBA::Object_var b = client_->resolve("hostB.host_cxt/Diagnostic0.rtc");
  EXPECT_FALSE(a->_is_equivalent(b));
  EXPECT_FALSE(rtc::is_gone(a));
  EXPECT_FALSE(rtc::is_gone(b));
  const auto roots = client_->list();
  EXPECT_EQ(roots.size(), 2u);
}

TEST_F(Naming, ReplicasOnOneHostTakeTheNextInstanceNumber) {
  EXPECT_EQ(start_manager("a", "shared", kConfig), "shared.host_cxt/Diagnostic0.rtc\n");
  EXPECT_EQ(start_manager("b", "shared", kConfig + std::string("  - type: Diagnostic\n")),
            "shared.host_cxt/Diagnostic1.rtc\nshared.host_cxt/Diagnostic2.rtc\n");
  EXPECT_EQ(instance_of("shared.host_cxt/Diagnostic0.rtc"), "Diagnostic0");
  EXPECT_EQ(instance_of("shared.host_cxt/Diagnostic1.rtc"), "Diagnostic1");
  EXPECT_EQ(instance_of("shared.host_cxt/Diagnostic2.rtc"), "Diagnostic2");
}

TEST_F(Naming, AStaleBindingIsRepairedAndACleanExitUnbinds) {
  start_manager("a", "shared", kConfig);
  start_manager("b", "shared", kConfig);  // Diagnostic1
  manager("a").kill9();
  CORBA::Object_var stale = client_->resolve("shared.host_cxt/Diagnostic0.rtc");
  EXPECT_TRUE(rtc::is_gone(stale));  // the binding outlives its process

  forget_manager("a");
  EXPECT_EQ(start_manager("a", "shared", kConfig), "shared.host_cxt/Diagnostic0.rtc\n");
  CORBA::Object_var repaired = client_->resolve("shared.host_cxt/Diagnostic0.rtc");
  EXPECT_FALSE(rtc::is_gone(repaired));
  EXPECT_EQ(instance_of("shared.host_cxt/Diagnostic1.rtc"), "Diagnostic1");  // untouched

  manager("b").signal(SIGTERM);
  EXPECT_EQ(manager("b").wait(10s), 0);
  CORBA::Object_var gone = client_->try_resolve("shared.host_cxt/Diagnostic1.rtc");
  EXPECT_TRUE(CORBA::is_nil(gone));
  CORBA::Object_var kept = client_->try_resolve("shared.host_cxt/Diagnostic0.rtc");
  EXPECT_FALSE(CORBA::is_nil(kept));
}

TEST_F(Naming, AnExplicitInstanceNameHeldByALiveComponentIsAnError) {
  const std::string config = "components:\n  - type: Diagnostic\n    instance: Front\n";
  EXPECT_EQ(start_manager("a", "shared", config), "shared.host_cxt/Front.rtc\n");
  const std::string path = dir_ + "/second.yaml";
  std::ofstream(path) << config;
  auto result = run_command(
      {URS_RTC_MANAGER_BIN, "--space", "lab", "--naming", naming_->address(), "--host", "shared", "--config", path});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("Front is already bound to a live component"), std::string::npos) << result.err;
  CORBA::Object_var kept = client_->resolve("shared.host_cxt/Front.rtc");
  EXPECT_FALSE(rtc::is_gone(kept));
}

TEST_F(Naming, AnUnreachableNamingServiceIsReportedNotHung) {
  const std::string path = dir_ + "/c.yaml";
  std::ofstream(path) << kConfig;
  auto result = run_command({URS_RTC_MANAGER_BIN, "--space", "lab", "--naming",
                             "127.0.0.1:" + std::to_string(free_tcp_port()), "--config", path},
                            30s);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("unreachable"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace urs::test
