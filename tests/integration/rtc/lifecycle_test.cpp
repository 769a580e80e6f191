// Lifecycle, execution contexts and the SDO/RTObject operations tools call, through real CORBA
// object references: components hosted in this process (for hooks that fail on demand) and in a
// urs-rtc-manager process found through a real omniNames.

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "rt_space.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

// Counts its callbacks; on_execute fails while `fail_execute` is set, on_reset while `fail_reset`.
class ProbeComponent : public rtc::Component {
 public:
  ProbeComponent() : Component({"Probe", "test component", "1.0", "URSLink", "Test"}) {}
  std::atomic<int> activated{0}, deactivated{0}, executed{0}, aborting{0}, errors{0}, resets{0}, rate_changes{0};
  std::atomic<bool> fail_execute{false}, fail_reset{false};

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    declare_parameter("gain", "2.5");
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override {
    ++activated;
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override {
    ++deactivated;
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_execute(RTC::ExecutionContextHandle_t) override {
    ++executed;
    return fail_execute ? RTC::RTC_ERROR : RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_aborting(RTC::ExecutionContextHandle_t) override {
    ++aborting;
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_error(RTC::ExecutionContextHandle_t) override {
    ++errors;
    return RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_reset(RTC::ExecutionContextHandle_t) override {
    ++resets;
    return fail_reset ? RTC::RTC_ERROR : RTC::RTC_OK;
  }
  RTC::ReturnCode_t handle_rate_changed(RTC::ExecutionContextHandle_t) override {
    ++rate_changes;
    return RTC::RTC_OK;
  }
};

class Lifecycle : public ::testing::Test {
 protected:
  void SetUp() override {
    for (auto* probe : {&a_, &b_}) {
      probe->setup(test_orb(), probe == &a_ ? "ProbeA0" : "ProbeB0", 200.0);
      ASSERT_EQ(probe->initialize(), RTC::RTC_OK);
    }
    ref_a_ = a_.reference();
    ref_b_ = b_.reference();
    RTC::ExecutionContextList_var owned = ref_a_->get_owned_contexts();
    ASSERT_EQ(owned->length(), 1u);
    ec_a_ = RTC::ExecutionContext::_duplicate(owned[0]);
  }
  void TearDown() override {
    a_.exit();
    b_.exit();
  }

  ProbeComponent a_, b_;
  RTC::RTObject_var ref_a_, ref_b_;
  RTC::ExecutionContext_var ec_a_;
};

TEST_F(Lifecycle, ActivationIsSynchronousAndReturnsTheSpecifiedCodes) {
  EXPECT_TRUE(ec_a_->is_running());
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::INACTIVE);
  EXPECT_EQ(ec_a_->get_component_state(ref_b_), RTC::CREATED);  // not a participant
  EXPECT_EQ(ec_a_->activate_component(ref_b_), RTC::BAD_PARAMETER);
  EXPECT_EQ(ec_a_->deactivate_component(ref_a_), RTC::PRECONDITION_NOT_MET);  // not active
  EXPECT_EQ(ec_a_->reset_component(ref_a_), RTC::PRECONDITION_NOT_MET);       // not in error

  ASSERT_EQ(ec_a_->activate_component(ref_a_), RTC::RTC_OK);
  // Synchronous: the transition has happened when the call returns.
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::ACTIVE);
  EXPECT_EQ(a_.activated.load(), 1);
  EXPECT_EQ(ec_a_->activate_component(ref_a_), RTC::PRECONDITION_NOT_MET);
  EXPECT_TRUE(wait_until([&] { return a_.executed > 3; }, 5s));

  ASSERT_EQ(ec_a_->deactivate_component(ref_a_), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::INACTIVE);
  EXPECT_EQ(a_.deactivated.load(), 1);
  const int executed = a_.executed;
  // An inactive component is not executed: b, active in the same context, runs meanwhile.
  ASSERT_EQ(ec_a_->add_component(ref_b_), RTC::RTC_OK);
  ASSERT_EQ(ec_a_->activate_component(ref_b_), RTC::RTC_OK);
  const int b_before = b_.executed;
  ASSERT_TRUE(wait_until([&] { return b_.executed > b_before + 3; }, 5s));
  EXPECT_EQ(a_.executed.load(), executed);
}

TEST_F(Lifecycle, AFailingExecutionGoesToErrorAndResetRecovers) {
  a_.fail_execute = true;
  ASSERT_EQ(ec_a_->activate_component(ref_a_), RTC::RTC_OK);
  ASSERT_TRUE(wait_until([&] { return ec_a_->get_component_state(ref_a_) == RTC::ERROR; }, 5s));
  EXPECT_EQ(a_.aborting.load(), 1);
  EXPECT_TRUE(wait_until([&] { return a_.errors > 2; }, 5s));  // on_error runs while in Error
  EXPECT_EQ(ec_a_->activate_component(ref_a_), RTC::PRECONDITION_NOT_MET);

  a_.fail_reset = true;
  EXPECT_EQ(ec_a_->reset_component(ref_a_), RTC::RTC_ERROR);
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::ERROR);

  a_.fail_reset = false;
  a_.fail_execute = false;
  ASSERT_EQ(ec_a_->reset_component(ref_a_), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::INACTIVE);
  ASSERT_EQ(ec_a_->activate_component(ref_a_), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::ACTIVE);
}

TEST_F(Lifecycle, AComponentTakesPartInAnotherComponentsContextFromHandle1000) {
  ASSERT_EQ(ec_a_->add_component(ref_b_), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->add_component(ref_b_), RTC::PRECONDITION_NOT_MET);
  RTC::ExecutionContextList_var participating = ref_b_->get_participating_contexts();
  ASSERT_EQ(participating->length(), 1u);
  EXPECT_EQ(ref_b_->get_context_handle(ec_a_), 1000);
  EXPECT_EQ(ref_a_->get_context_handle(ec_a_), 0);
  EXPECT_TRUE(ref_b_->is_alive(ec_a_));
  RTC::ExecutionContext_var by_handle = ref_b_->get_context(1000);
  EXPECT_TRUE(by_handle->_is_equivalent(ec_a_));

  ASSERT_EQ(ec_a_->activate_component(ref_b_), RTC::RTC_OK);
  EXPECT_TRUE(wait_until([&] { return b_.executed > 2; }, 5s));
  EXPECT_EQ(ec_a_->remove_component(ref_b_), RTC::PRECONDITION_NOT_MET);  // still active
  ASSERT_EQ(ec_a_->deactivate_component(ref_b_), RTC::RTC_OK);
  ASSERT_EQ(ec_a_->remove_component(ref_b_), RTC::RTC_OK);
  participating = ref_b_->get_participating_contexts();
  EXPECT_EQ(participating->length(), 0u);
  EXPECT_EQ(ec_a_->get_component_state(ref_b_), RTC::CREATED);
  EXPECT_EQ(ec_a_->remove_component(ref_b_), RTC::BAD_PARAMETER);
}

TEST_F(Lifecycle, RateAndProfileOfTheExecutionContext) {
  EXPECT_DOUBLE_EQ(ec_a_->get_rate(), 200.0);
  EXPECT_EQ(ec_a_->set_rate(-1.0), RTC::BAD_PARAMETER);
  EXPECT_EQ(ec_a_->set_rate(0.0), RTC::BAD_PARAMETER);
  ASSERT_EQ(ec_a_->set_rate(50.0), RTC::RTC_OK);
  EXPECT_DOUBLE_EQ(ec_a_->get_rate(), 50.0);
  EXPECT_EQ(a_.rate_changes.load(), 1);
  EXPECT_EQ(ec_a_->get_kind(), RTC::PERIODIC);
  RTC::ExecutionContextService_var service = RTC::ExecutionContextService::_narrow(ec_a_);
  ASSERT_FALSE(CORBA::is_nil(service));
  RTC::ExecutionContextProfile_var profile = service->get_profile();
  EXPECT_DOUBLE_EQ(profile->rate, 50.0);
  EXPECT_TRUE(profile->owner->_is_equivalent(ref_a_));
  ASSERT_EQ(profile->participants.length(), 1u);

  EXPECT_EQ(ec_a_->stop(), RTC::RTC_OK);
  EXPECT_FALSE(ec_a_->is_running());
  EXPECT_EQ(ec_a_->stop(), RTC::PRECONDITION_NOT_MET);
  // A stopped context makes transitions in the caller's thread.
  EXPECT_EQ(ec_a_->activate_component(ref_a_), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->get_component_state(ref_a_), RTC::ACTIVE);
  EXPECT_EQ(ec_a_->start(), RTC::RTC_OK);
  EXPECT_EQ(ec_a_->start(), RTC::PRECONDITION_NOT_MET);
  EXPECT_TRUE(wait_until([&] { return a_.executed > 0; }, 5s));
}

TEST_F(Lifecycle, SdoOperationsAnswerWithoutCrashing) {
  CORBA::String_var id = ref_a_->get_sdo_id();
  EXPECT_STREQ(id.in(), "ProbeA0");
  CORBA::String_var type = ref_a_->get_sdo_type();
  EXPECT_STREQ(type.in(), "Probe");
  SDOPackage::DeviceProfile_var device = ref_a_->get_device_profile();
  EXPECT_STREQ(device->manufacturer.in(), "URSLink");
  SDOPackage::ServiceProfileList_var services = ref_a_->get_service_profiles();
  EXPECT_EQ(services->length(), 0u);
  SDOPackage::OrganizationList_var organizations = ref_a_->get_organizations();
  EXPECT_EQ(organizations->length(), 0u);
  SDOPackage::OrganizationList_var owned = ref_a_->get_owned_organizations();
  EXPECT_EQ(owned->length(), 0u);
  SDOPackage::NVList_var status = ref_a_->get_status_list();
  EXPECT_EQ(status->length(), 0u);
  EXPECT_THROW(ref_a_->get_service_profile("x"), SDOPackage::InvalidParameter);
  EXPECT_THROW(ref_a_->get_sdo_service("x"), SDOPackage::InvalidParameter);
  EXPECT_THROW(ref_a_->get_status("x"), SDOPackage::InvalidParameter);
  SDOPackage::Configuration_var configuration = ref_a_->get_configuration();
  ASSERT_FALSE(CORBA::is_nil(configuration));
  SDOPackage::ConfigurationSet_var active = configuration->get_active_configuration_set();
  EXPECT_STREQ(active->id.in(), "default");
  SDOPackage::ConfigurationSetList_var sets = configuration->get_configuration_sets();
  ASSERT_EQ(sets->length(), 1u);
  EXPECT_TRUE(configuration->activate_configuration_set("default"));
  EXPECT_THROW(configuration->activate_configuration_set("other"), SDOPackage::InvalidParameter);
  EXPECT_THROW(configuration->get_configuration_set("other"), SDOPackage::NotAvailable);
  EXPECT_THROW(configuration->add_configuration_set(active.in()), SDOPackage::InvalidParameter);  // exists
  ASSERT_EQ(active->configuration_data.length(), 1u);
  CORBA::Any_var gain = configuration->get_configuration_parameter_value("gain");
  const char* text = nullptr;
  ASSERT_TRUE(gain.in() >>= text);
  EXPECT_STREQ(text, "2.5");
  EXPECT_THROW(configuration->get_configuration_parameter_value("nope"), SDOPackage::InvalidParameter);
  EXPECT_THROW(ref_a_->get_monitoring(), SDOPackage::InterfaceNotImplemented);
  EXPECT_EQ(ref_a_->finalize(), RTC::PRECONDITION_NOT_MET);
  EXPECT_EQ(ref_a_->initialize(), RTC::PRECONDITION_NOT_MET);  // already initialized
  RTC::ComponentProfile_var profile = ref_a_->get_component_profile();
  EXPECT_STREQ(profile->instance_name.in(), "ProbeA0");
  EXPECT_STREQ(profile->type_name.in(), "Probe");
  EXPECT_TRUE(ref_a_->_is_a("IDL:openrtm.aist.go.jp/OpenRTM/DataFlowComponent:1.0"));
}

TEST_F(Lifecycle, ExitDeactivatesFinalizesAndRefusesASecondExit) {
  ASSERT_EQ(ec_a_->activate_component(ref_a_), RTC::RTC_OK);
  ASSERT_EQ(ref_a_->exit(), RTC::RTC_OK);
  EXPECT_EQ(a_.deactivated.load(), 1);
  EXPECT_EQ(a_.exit(), RTC::PRECONDITION_NOT_MET);
}

// ---- a component in a manager process, found through omniNames ----

class ManagedLifecycle : public RtSpaceTest {};

TEST_F(ManagedLifecycle, ToolsActivateAComponentFoundInTheNamingService) {
  const std::string bound = start_manager("m", "labhost", "components:\n  - type: Diagnostic\n");
  EXPECT_EQ(bound, "labhost.host_cxt/Diagnostic0.rtc\n");
  auto rtc = resolve<RTC::RTObject>("labhost.host_cxt/Diagnostic0.rtc");
  ASSERT_FALSE(CORBA::is_nil(rtc));
  EXPECT_EQ(rtc::component_state(rtc), RTC::INACTIVE);
  RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
  ASSERT_EQ(contexts->length(), 1u);
  EXPECT_EQ(contexts[0]->activate_component(rtc), RTC::RTC_OK);
  EXPECT_EQ(rtc::component_state(rtc), RTC::ACTIVE);
  EXPECT_EQ(contexts[0]->activate_component(rtc), RTC::PRECONDITION_NOT_MET);
  EXPECT_EQ(contexts[0]->deactivate_component(rtc), RTC::RTC_OK);
  EXPECT_EQ(rtc::component_state(rtc), RTC::INACTIVE);

  RTC::ComponentProfile_var profile = rtc->get_component_profile();
  EXPECT_STREQ(profile->instance_name.in(), "Diagnostic0");
  SDOPackage::Configuration_var configuration = rtc->get_configuration();
  SDOPackage::NVList_var values = configuration->get_configuration_parameter_values();
  EXPECT_EQ(values->length(), 0u);  // Diagnostic declares no parameter
  ASSERT_EQ(profile->port_profiles.length(), 1u);
  EXPECT_STREQ(profile->port_profiles[0].name.in(), "Diagnostic0.diagnostic");

  // exit() through CORBA: the component unbinds itself, the manager keeps running.
  EXPECT_EQ(rtc->exit(), RTC::RTC_OK);
  EXPECT_TRUE(wait_until(
      [&] {
        CORBA::Object_var object = client_->try_resolve("labhost.host_cxt/Diagnostic0.rtc");
        return CORBA::is_nil(object);
      },
      5s));
  EXPECT_TRUE(manager("m").running());
}

TEST_F(ManagedLifecycle, ActivateFromConfigAndUnbindOnCleanExit) {
  start_manager("m", "labhost", "rate: 20\ncomponents:\n  - type: Diagnostic\n    activate: true\n");
  auto rtc = resolve<RTC::RTObject>("labhost.host_cxt/Diagnostic0.rtc");
  EXPECT_EQ(rtc::component_state(rtc), RTC::ACTIVE);
  RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
  EXPECT_DOUBLE_EQ(contexts[0]->get_rate(), 20.0);
  manager("m").signal(SIGTERM);
  EXPECT_EQ(manager("m").wait(10s), 0);
  CORBA::Object_var object = client_->try_resolve("labhost.host_cxt/Diagnostic0.rtc");
  EXPECT_TRUE(CORBA::is_nil(object));
}

TEST_F(ManagedLifecycle, BadConfigurationIsRefusedWithTheReason) {
  const std::string config = dir_ + "/bad.yaml";
  std::ofstream(config) << "components:\n  - type: NoSuchType\n  - type: Diagnostic\n    rate: -3\n    colour: red\n";
  auto result =
      run_command({URS_RTC_MANAGER_BIN, "--space", "lab", "--naming", naming_->address(), "--config", config});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("components[1].rate"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("components[1].colour: unknown key"), std::string::npos) << result.err;

  std::ofstream(config, std::ios::trunc) << "components:\n  - type: NoSuchType\n";
  result = run_command({URS_RTC_MANAGER_BIN, "--space", "lab", "--naming", naming_->address(), "--config", config});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("unknown component type 'NoSuchType'"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace urs::test
