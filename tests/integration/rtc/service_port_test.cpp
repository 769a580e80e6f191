// Service ports on the wire: a consumer in this process and one in a manager process call the
// Diagnostic provider of a urs-rtc-manager process through connected ports, with the provider's
// IOR published under both key styles; the minimal foreign route; dead peers dropped; a second
// connection between the same ports refused, as OpenRTM-aist 2.x refuses it.

#include <gtest/gtest.h>
#include <signal.h>

#include <thread>

#include "Diagnostic.hh"
#include "rt_space.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kProviderPath = "labhost.host_cxt/Diagnostic0.rtc";
constexpr const char* kNewKey = "Diagnostic0.port.diagnostic.provided.URS::Diagnostic.diagnostic";
constexpr const char* kOldKey = "port.URS::Diagnostic.diagnostic";

class ServicePort : public RtSpaceTest {
 protected:
  void SetUp() override {
    RtSpaceTest::SetUp();
    start_manager("provider", "labhost", "components:\n  - type: Diagnostic\n");
    auto rtc = resolve<RTC::RTObject>(kProviderPath);
    provider_port_ = rtc::find_port(rtc, "diagnostic");
    ASSERT_FALSE(CORBA::is_nil(provider_port_));
  }
  void TearDown() override {
    for (auto& consumer : consumers_) consumer->exit();
    RtSpaceTest::TearDown();
  }

  DiagnosticConsumer& make_consumer(const std::string& interface_instance) {
    consumers_.push_back(std::make_unique<DiagnosticConsumer>("TestConsumer", interface_instance));
    auto& consumer = *consumers_.back();
    consumer.setup(test_orb(), "TestConsumer" + std::to_string(consumers_.size() - 1), 100.0);
    EXPECT_EQ(consumer.initialize(), RTC::RTC_OK);
    return consumer;
  }

  RTC::PortService_var provider_port_;
  std::vector<std::unique_ptr<DiagnosticConsumer>> consumers_;
};

TEST_F(ServicePort, AConsumerCallsTheProviderThroughAConnectedPort) {
  auto& consumer = make_consumer("diagnostic");
  RTC::PortService_var port = consumer.port();
  EXPECT_FALSE(consumer.consumer().connected());
  auto connection = rtc::connect_ports({port.in(), provider_port_.in()}, "diag");
  ASSERT_EQ(connection.code, RTC::RTC_OK);
  const auto new_style = rtc::nv_string(connection.profile.properties, kNewKey);
  const auto old_style = rtc::nv_string(connection.profile.properties, kOldKey);
  ASSERT_TRUE(new_style && old_style);
  EXPECT_EQ(new_style->rfind("IOR:", 0), 0u);
  EXPECT_EQ(*new_style, *old_style);

  URS::Diagnostic_var diagnostic = consumer.consumer().get<URS::Diagnostic>();
  ASSERT_FALSE(CORBA::is_nil(diagnostic));
  CORBA::String_var echoed = diagnostic->echo("hello RT");
  EXPECT_STREQ(echoed.in(), "hello RT");
  EXPECT_DOUBLE_EQ(diagnostic->add(1.5, 2.25), 3.75);
  URS::OctetSeq_var image = diagnostic->blob(921600);
  ASSERT_EQ(image->length(), 921600u);
  EXPECT_EQ(image[251], 0);
  EXPECT_EQ(image[1000], 1000 % 251);
  EXPECT_EQ(diagnostic->checksum(image.in()), diagnostic->checksum(image.in()));
  try {
    diagnostic->fail("on purpose", 42);
    ADD_FAILURE() << "fail() returned";
  } catch (const URS::Failure& failure) {
    EXPECT_STREQ(failure.reason.in(), "on purpose");
    EXPECT_EQ(failure.code, 42);
  }

  // Both ports list the connection under the same id.
  RTC::ConnectorProfileList_var mine = port->get_connector_profiles();
  RTC::ConnectorProfileList_var theirs = provider_port_->get_connector_profiles();
  ASSERT_EQ(mine->length(), 1u);
  ASSERT_EQ(theirs->length(), 1u);
  EXPECT_STREQ(mine[0].connector_id.in(), theirs[0].connector_id.in());
  EXPECT_STREQ(mine[0].connector_id.in(), connection.profile.connector_id.in());

  EXPECT_EQ(rtc::disconnect_ports(port, provider_port_), 1);
  EXPECT_FALSE(consumer.consumer().connected());
  theirs = provider_port_->get_connector_profiles();
  EXPECT_EQ(theirs->length(), 0u);
}

// connect() with exactly the given properties, as a foreign tool would call it.
RTC::ConnectorProfile raw_connect(RTC::PortService_ptr first, RTC::PortService_ptr second,
                                  const SDOPackage::NVList& properties, RTC::ReturnCode_t& code) {
  RTC::ConnectorProfile profile;
  profile.name = CORBA::string_dup("raw");
  profile.connector_id = CORBA::string_dup("");
  profile.ports.length(2);
  profile.ports[0] = RTC::PortService::_duplicate(first);
  profile.ports[1] = RTC::PortService::_duplicate(second);
  profile.properties = properties;
  code = first->connect(profile);
  return profile;
}

TEST_F(ServicePort, TheRequiredKeyPicksAProviderWhoseInstanceNameDiffers) {
  auto& consumer = make_consumer("my_diagnostic");  // the old-style key cannot match
  RTC::PortService_var port = consumer.port();
  RTC::ReturnCode_t code = RTC::RTC_ERROR;
  auto loose = raw_connect(port, provider_port_, {}, code);
  EXPECT_EQ(code, RTC::RTC_OK);  // best effort: connected, but nothing to call
  EXPECT_FALSE(consumer.consumer().connected());
  port->disconnect(loose.connector_id);

  raw_connect(port, provider_port_, rtc::nv_from({{"port.connection.strictness", "strict"}}), code);
  EXPECT_EQ(code, RTC::RTC_ERROR);
  RTC::ConnectorProfileList_var none = port->get_connector_profiles();
  EXPECT_EQ(none->length(), 0u);
  RTC::ConnectorProfileList_var none_there = provider_port_->get_connector_profiles();
  EXPECT_EQ(none_there->length(), 0u);

  const std::string required_key = "TestConsumer0.port.diagnostic.required.URS::Diagnostic.my_diagnostic";
  raw_connect(port, provider_port_, rtc::nv_from({{required_key, kNewKey}}), code);
  ASSERT_EQ(code, RTC::RTC_OK);
  URS::Diagnostic_var diagnostic = consumer.consumer().get<URS::Diagnostic>();
  ASSERT_FALSE(CORBA::is_nil(diagnostic));
  CORBA::String_var echoed = diagnostic->echo("mapped");
  EXPECT_STREQ(echoed.in(), "mapped");
  EXPECT_EQ(rtc::disconnect_ports(port, provider_port_), 1);
  EXPECT_FALSE(consumer.consumer().connected());

  // connect_ports() writes that key itself when one provider of the type is on offer.
  auto mapped = rtc::connect_ports({port.in(), provider_port_.in()}, "mapped");
  ASSERT_EQ(mapped.code, RTC::RTC_OK);
  EXPECT_EQ(rtc::nv_string(mapped.profile.properties, required_key), std::string(kNewKey));
  EXPECT_TRUE(consumer.consumer().connected());
}

TEST_F(ServicePort, ASecondConnectionToTheSamePeerIsRefusedAsOpenRtmRefusesIt) {
  auto& consumer = make_consumer("diagnostic");
  RTC::PortService_var port = consumer.port();
  ASSERT_EQ(rtc::connect_ports({port.in(), provider_port_.in()}, "first").code, RTC::RTC_OK);
  // Either order, either port first: each port already holds a connection to the other.
  EXPECT_EQ(rtc::connect_ports({port.in(), provider_port_.in()}, "again").code, RTC::PRECONDITION_NOT_MET);
  EXPECT_EQ(rtc::connect_ports({provider_port_.in(), port.in()}, "again").code, RTC::PRECONDITION_NOT_MET);
  RTC::ConnectorProfileList_var theirs = provider_port_->get_connector_profiles();
  EXPECT_EQ(theirs->length(), 1u);
  // Unless the connector allows it.
  EXPECT_EQ(rtc::connect_ports({port.in(), provider_port_.in()}, "dup",
                               rtc::nv_from({{"dataport.allow_dup_connection", "YES"}}))
                .code,
            RTC::RTC_OK);
  theirs = provider_port_->get_connector_profiles();
  EXPECT_EQ(theirs->length(), 2u);
}

TEST_F(ServicePort, TheMinimalForeignRouteNeedsOnlyTheProvidersPort) {
  RTC::ReturnCode_t code = RTC::RTC_ERROR;
  const RTC::ConnectorProfile profile = connect_alone(provider_port_, code);
  ASSERT_EQ(code, RTC::RTC_OK);
  EXPECT_EQ(std::string(profile.connector_id.in()).size(), 36u);  // a UUID was assigned
  const auto ior = rtc::nv_string(profile.properties, kOldKey);
  ASSERT_TRUE(ior);
  CORBA::Object_var object = test_orb().string_to_object(*ior);
  URS::Diagnostic_var diagnostic = URS::Diagnostic::_narrow(object);
  CORBA::String_var echoed = diagnostic->echo("foreign");
  EXPECT_STREQ(echoed.in(), "foreign");
  EXPECT_EQ(provider_port_->disconnect(profile.connector_id), RTC::RTC_OK);
  EXPECT_EQ(provider_port_->disconnect(profile.connector_id), RTC::BAD_PARAMETER);
}

TEST_F(ServicePort, AConsumerInAManagerCallsThroughAndADeadPeerIsDropped) {
  start_manager("caller", "otherhost", "rate: 200\ncomponents:\n  - type: DiagnosticCaller\n");
  auto caller = resolve<RTC::RTObject>("otherhost.host_cxt/DiagnosticCaller0.rtc");
  RTC::PortService_var caller_port = rtc::find_port(caller, "DiagnosticCaller0.diagnostic");
  ASSERT_FALSE(CORBA::is_nil(caller_port));
  ASSERT_EQ(rtc::connect_ports({caller_port.in(), provider_port_.in()}, "caller").code, RTC::RTC_OK);
  RTC::ExecutionContextList_var contexts = caller->get_owned_contexts();
  ASSERT_EQ(contexts[0]->activate_component(caller), RTC::RTC_OK);
  ASSERT_TRUE(wait_until([&] { return manager("caller").log().find("first echo reply") != std::string::npos; }, 10s))
      << manager("caller").log();
  ASSERT_EQ(contexts[0]->deactivate_component(caller), RTC::RTC_OK);
  ASSERT_TRUE(wait_until([&] { return manager("caller").log().find("echo replies") != std::string::npos; }, 5s));
  const std::string log = manager("caller").log();
  EXPECT_EQ(log.find(" 0 echo replies"), std::string::npos) << log;
  EXPECT_NE(log.find(", 0 failures"), std::string::npos) << log;

  RTC::ConnectorProfileList_var before = provider_port_->get_connector_profiles();
  ASSERT_EQ(before->length(), 1u);
  manager("caller").kill9();
  RTC::ConnectorProfileList_var after = provider_port_->get_connector_profiles();
  EXPECT_EQ(after->length(), 0u);  // the peer port no longer exists
}

}  // namespace
}  // namespace urs::test
