// Pieces of the RT runtime that need no peer: naming paths, NVList helpers, the connector
// properties tools compute, connector ids, the manager's configuration file, the ORB's flags.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>

#include "urs/rtc/configuration.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/orb_flags.hpp"
#include "urs/rtc/port.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/util/cli.hpp"

namespace urs::rtc {
namespace {

// Strings in an Any need the ORB's code-set converters, which ORB_init installs.
Orb& orb() {
  static Orb instance;
  return instance;
}

class RtcUnit : public ::testing::Test {
 protected:
  void SetUp() override { orb(); }
};

TEST_F(RtcUnit, NamingPathsSplitIdAndKindAtTheLastDot) {
  const CosNaming::Name name = to_name("lab.example.org.host_cxt/Robot0.rtc");
  ASSERT_EQ(name.length(), 2u);
  EXPECT_STREQ(name[0].id.in(), "lab.example.org");
  EXPECT_STREQ(name[0].kind.in(), "host_cxt");
  EXPECT_STREQ(name[1].id.in(), "Robot0");
  EXPECT_STREQ(name[1].kind.in(), "rtc");
  EXPECT_EQ(to_path(name), "lab.example.org.host_cxt/Robot0.rtc");
  EXPECT_EQ(to_path(to_name("plain")), "plain");
  EXPECT_EQ(component_path("h", "Robot0"), "h.host_cxt/Robot0.rtc");
  EXPECT_THROW(to_name(""), std::invalid_argument);
  EXPECT_THROW(to_name("a//b"), std::invalid_argument);
}

TEST_F(RtcUnit, NvListKeepsOneEntryPerNameAndReadsOnlyStrings) {
  SDOPackage::NVList list;
  nv_set(list, "a", "1");
  nv_set(list, "a", "2");
  nv_set(list, "b", "x");
  list.length(3);
  list[2].name = CORBA::string_dup("n");
  list[2].value <<= static_cast<CORBA::Long>(7);
  EXPECT_EQ(list.length(), 3u);
  EXPECT_EQ(nv_string(list, "a"), "2");
  EXPECT_EQ(nv_string(list, "n"), std::nullopt);  // a long, not a string
  EXPECT_EQ(nv_string(list, "missing"), std::nullopt);
  EXPECT_TRUE(nv_has(list, "n"));
  EXPECT_EQ(any_to_text(list[2].value), "7");
  EXPECT_EQ(nv_lines(list), (std::vector<std::string>{"a=2", "b=x", "n=7"}));
  nv_append(list, nv_from({{"b", "y"}, {"c", "z"}}));
  EXPECT_EQ(nv_lines(list), (std::vector<std::string>{"a=2", "b=y", "n=7", "c=z"}));
  CORBA::Object_var none = nv_object(list, "a");
  EXPECT_TRUE(CORBA::is_nil(none));
}

RTC::PortProfile port_profile(const std::string& name, const std::string& type,
                              std::vector<std::tuple<std::string, std::string, RTC::PortInterfacePolarity>> interfaces,
                              const std::string& data_type = {}) {
  RTC::PortProfile profile;
  profile.name = CORBA::string_dup(name.c_str());
  profile.interfaces.length(static_cast<CORBA::ULong>(interfaces.size()));
  for (CORBA::ULong i = 0; i < interfaces.size(); ++i) {
    profile.interfaces[i].instance_name = CORBA::string_dup(std::get<0>(interfaces[i]).c_str());
    profile.interfaces[i].type_name = CORBA::string_dup(std::get<1>(interfaces[i]).c_str());
    profile.interfaces[i].polarity = std::get<2>(interfaces[i]);
  }
  nv_set(profile.properties, "port.port_type", type);
  if (!data_type.empty()) nv_set(profile.properties, "dataport.data_type", data_type);
  return profile;
}

TEST_F(RtcUnit, ConnectorPropertiesMapARequiredInterfaceToItsOnlyProvider) {
  const auto consumer = port_profile("Caller0.diagnostic", "CorbaPort", {{"mine", "URS::Diagnostic", RTC::REQUIRED}});
  const auto provider =
      port_profile("Diagnostic0.diagnostic", "CorbaPort", {{"diagnostic", "URS::Diagnostic", RTC::PROVIDED}});
  const auto props = connector_properties({consumer, provider}, {});
  EXPECT_EQ(nv_string(props, "Caller0.port.diagnostic.required.URS::Diagnostic.mine"),
            "Diagnostic0.port.diagnostic.provided.URS::Diagnostic.diagnostic");
  EXPECT_FALSE(nv_has(props, "dataport.interface_type"));  // no data port involved

  // Two providers of the type: the choice is the caller's, nothing is guessed.
  const auto other =
      port_profile("Diagnostic1.diagnostic", "CorbaPort", {{"diagnostic", "URS::Diagnostic", RTC::PROVIDED}});
  EXPECT_FALSE(nv_has(connector_properties({consumer, provider, other}, {}),
                      "Caller0.port.diagnostic.required.URS::Diagnostic.mine"));
  // What the caller sets wins.
  const auto given = connector_properties({consumer, provider},
                                          nv_from({{"Caller0.port.diagnostic.required.URS::Diagnostic.mine", "x"}}));
  EXPECT_EQ(nv_string(given, "Caller0.port.diagnostic.required.URS::Diagnostic.mine"), "x");
}

TEST_F(RtcUnit, ConnectorPropertiesFillDataPortDefaultsFromTheOutPort) {
  const auto out = port_profile("Counter0.count", "DataOutPort", {}, "IDL:RTC/TimedLong:1.0");
  const auto in = port_profile("Sink0.count", "DataInPort", {}, "IDL:RTC/TimedLong:1.0");
  const auto props = connector_properties({in, out}, nv_from({{"dataport.subscription_type", "new"}}));
  EXPECT_EQ(nv_string(props, "dataport.interface_type"), "corba_cdr");
  EXPECT_EQ(nv_string(props, "dataport.dataflow_type"), "push");
  EXPECT_EQ(nv_string(props, "dataport.subscription_type"), "new");
  EXPECT_EQ(nv_string(props, "dataport.serializer.cdr.endian"), "little");
  EXPECT_EQ(nv_string(props, "dataport.data_type"), "IDL:RTC/TimedLong:1.0");
}

TEST_F(RtcUnit, TypeNamesMatchAcrossScopedNamesRepositoryIdsAndBareNames) {
  EXPECT_TRUE(same_type_name("URC::Navigation", "IDL:URC/Navigation:1.0"));
  EXPECT_TRUE(same_type_name("Navigation", "URC::Navigation"));
  EXPECT_TRUE(same_type_name("TimedLong", "IDL:RTC/TimedLong:1.0"));
  EXPECT_FALSE(same_type_name("SimpleService::MyService", "URS::Diagnostic"));
  EXPECT_FALSE(same_type_name("IDL:RTC/TimedLong:1.0", "IDL:RTC/TimedPose2D:1.0"));
  EXPECT_FALSE(same_type_name("A::Navigation", "B::Navigation"));
}

TEST_F(RtcUnit, ConnectionMismatchNamesBothSides) {
  const auto my_service = port_profile("MyServiceConsumer0.MyService", "CorbaPort",
                                       {{"myservice0", "SimpleService::MyService", RTC::REQUIRED}});
  const auto diagnostic =
      port_profile("Diagnostic0.diagnostic", "CorbaPort", {{"diagnostic", "URS::Diagnostic", RTC::PROVIDED}});
  EXPECT_EQ(connection_mismatch(my_service, diagnostic),
            "MyServiceConsumer0.MyService requires SimpleService::MyService but Diagnostic0.diagnostic provides "
            "URS::Diagnostic");
  EXPECT_EQ(connection_mismatch(diagnostic, my_service), connection_mismatch(my_service, diagnostic));
  const auto caller = port_profile("Caller0.diagnostic", "CorbaPort", {{"mine", "URS::Diagnostic", RTC::REQUIRED}});
  EXPECT_EQ(connection_mismatch(caller, diagnostic), "");
  EXPECT_EQ(connection_mismatch(diagnostic, caller), "");
  EXPECT_NE(connection_mismatch(diagnostic, diagnostic).find("neither"), std::string::npos);
  // A port without interfaces (the bridge's generic `providers`) is compatible with any.
  EXPECT_EQ(connection_mismatch(port_profile("Bridge0.providers", "CorbaPort", {}), diagnostic), "");

  const auto count = port_profile("Counter0.count", "DataOutPort", {}, "IDL:RTC/TimedLong:1.0");
  const auto pose_in = port_profile("Sink0.pose", "DataInPort", {}, "IDL:RTC/TimedPose2D:1.0");
  const auto count_in = port_profile("ConsoleOut0.in", "DataInPort", {}, "TimedLong");  // OpenRTM-aist 1.x style
  EXPECT_EQ(connection_mismatch(count, pose_in),
            "Counter0.count carries IDL:RTC/TimedLong:1.0 but Sink0.pose carries IDL:RTC/TimedPose2D:1.0");
  EXPECT_EQ(connection_mismatch(count, count_in), "");
  EXPECT_NE(connection_mismatch(count, count).find("are both DataOutPorts"), std::string::npos);
  EXPECT_NE(connection_mismatch(count, diagnostic).find("a data port connects to a data port"), std::string::npos);
  // Ports of an unknown kind: nothing can be said.
  EXPECT_EQ(connection_mismatch(port_profile("X0.x", "Other", {}), diagnostic), "");
}

// The configuration sets as tools drive them, called on the servant directly.
class ConfigurationUnit : public RtcUnit {
 protected:
  void SetUp() override {
    RtcUnit::SetUp();
    config_.declare(
        {"radius", "1", number_between(0, 10), [this](const std::string& v) { applied_.push_back("radius=" + v); }});
    config_.declare({"label", "a", {}, [this](const std::string& v) { applied_.push_back("label=" + v); }});
    config_.declare({"start", "0", {}, {}});  // read-only
  }

  static SDOPackage::ConfigurationSet set(const std::string& id,
                                          const std::vector<std::pair<std::string, std::string>>& values) {
    SDOPackage::ConfigurationSet out;
    out.id = CORBA::string_dup(id.c_str());
    out.description = CORBA::string_dup("");
    out.configuration_data = nv_from(values);
    return out;
  }

  std::string value(const std::string& set_id, const std::string& name) {
    SDOPackage::ConfigurationSet_var found = config_.get_configuration_set(set_id.c_str());
    return nv_string(found->configuration_data, name).value_or("<absent>");
  }

  static std::string refusal(const std::function<void()>& call) {
    try {
      call();
    } catch (const SDOPackage::InvalidParameter& e) {
      return e.description.in();
    }
    return "<accepted>";
  }

  ComponentConfiguration config_;
  std::vector<std::string> applied_;
};

TEST_F(ConfigurationUnit, ChangingTheActiveSetTellsTheComponentAtOnce) {
  EXPECT_TRUE(config_.set_configuration_set_values(set("default", {{"radius", "2.5"}})));
  EXPECT_EQ(applied_, (std::vector<std::string>{"radius=2.5"}));
  EXPECT_EQ(value("default", "radius"), "2.5");
  EXPECT_EQ(value("default", "label"), "a");  // the others are kept
  EXPECT_EQ(config_.active_value("radius"), "2.5");
  // The whole set sent back unchanged (as rtctree does) applies nothing more.
  EXPECT_TRUE(
      config_.set_configuration_set_values(set("default", {{"radius", "2.5"}, {"label", "a"}, {"start", "0"}})));
  EXPECT_TRUE(config_.activate_configuration_set("default"));
  EXPECT_EQ(applied_.size(), 1u);
  // Numbers and booleans in Anys are kept as text.
  SDOPackage::NVList change;
  change.length(1);
  change[0].name = CORBA::string_dup("radius");
  change[0].value <<= CORBA::Double(3);
  EXPECT_TRUE(config_.set_configuration_parameter("radius", change[0].value));
  EXPECT_EQ(value("default", "radius"), "3");
  EXPECT_EQ(applied_.back(), "radius=3");
}

TEST_F(ConfigurationUnit, SetsAreAddedActivatedAndRemoved) {
  EXPECT_TRUE(config_.add_configuration_set(set("fast", {{"radius", "9"}})));
  EXPECT_EQ(value("fast", "radius"), "9");
  EXPECT_EQ(value("fast", "label"), "a");  // a new set starts from the default values
  EXPECT_TRUE(applied_.empty());           // not active: nothing takes effect
  EXPECT_TRUE(config_.set_configuration_set_values(set("fast", {{"label", "b"}})));
  EXPECT_TRUE(applied_.empty());
  EXPECT_TRUE(config_.activate_configuration_set("fast"));
  EXPECT_EQ(applied_, (std::vector<std::string>{"radius=9", "label=b"}));
  SDOPackage::ConfigurationSet_var active = config_.get_active_configuration_set();
  EXPECT_STREQ(active->id.in(), "fast");
  EXPECT_EQ(refusal([&] { config_.remove_configuration_set("fast"); }),
            "configuration set 'fast' is active (activate another one first)");
  EXPECT_TRUE(config_.activate_configuration_set("default"));
  EXPECT_EQ(applied_.back(), "label=a");
  EXPECT_TRUE(config_.remove_configuration_set("fast"));
  SDOPackage::ConfigurationSetList_var sets = config_.get_configuration_sets();
  EXPECT_EQ(sets->length(), 1u);
  EXPECT_THROW(config_.get_configuration_set("fast"), SDOPackage::NotAvailable);
}

// A parameter declared OpenRTM-aist's way takes every value and does not use one it cannot: the
// call succeeds, the value in effect stays, and the set shows it again, in the active set as in
// a set activated later.
TEST_F(ConfigurationUnit, AValueNotTakenLeavesTheValueInEffectInTheSet) {
  config_.declare({"every", "1", {}, [this](const std::string& v) {
                     if (v.find_first_not_of("0123456789") != std::string::npos) throw ValueNotTaken("not a count");
                     applied_.push_back("every=" + v);
                   }});
  EXPECT_TRUE(config_.set_configuration_set_values(set("default", {{"every", "3"}})));
  EXPECT_TRUE(config_.set_configuration_set_values(set("default", {{"every", "often"}})));
  EXPECT_EQ(value("default", "every"), "3");
  EXPECT_EQ(config_.active_value("every"), "3");
  EXPECT_EQ(applied_, (std::vector<std::string>{"every=3"}));

  EXPECT_TRUE(config_.add_configuration_set(set("odd", {{"every", "x"}})));
  EXPECT_EQ(value("odd", "every"), "x");  // stored: nothing takes effect in a set not active
  EXPECT_TRUE(config_.activate_configuration_set("odd"));
  EXPECT_EQ(value("odd", "every"), "3");
  EXPECT_EQ(applied_.size(), 1u);
}

TEST_F(ConfigurationUnit, RefusalsSayWhatAndWhyAndChangeNothing) {
  EXPECT_EQ(refusal([&] {
              config_.set_configuration_set_values(set("default", {{"label", "b"}, {"radius", "wide"}}));
            }),
            "radius: 'wide' is not a number (set default unchanged)");
  EXPECT_EQ(value("default", "label"), "a");  // all or nothing
  EXPECT_EQ(refusal([&] {
              config_.set_configuration_set_values(set("default", {{"radius", "11"}}));
            }),
            "radius: '11' is outside 0 .. 10 (set default unchanged)");
  EXPECT_EQ(refusal([&] {
              config_.set_configuration_set_values(set("default", {{"start", "5"}}));
            }),
            "start is read-only (its value stays '0')");
  EXPECT_EQ(refusal([&] {
              config_.set_configuration_set_values(set("default", {{"gain", "5"}}));
            }),
            "no configuration parameter 'gain' (parameters: radius, label, start)");
  EXPECT_EQ(refusal([&] {
              config_.set_configuration_set_values(set("other", {{"radius", "5"}}));
            }),
            "no configuration set 'other' (add it first)");
  EXPECT_EQ(refusal([&] { config_.add_configuration_set(set("default", {})); }),
            "configuration set 'default' already exists");
  EXPECT_EQ(refusal([&] { config_.add_configuration_set(set("", {})); }), "the configuration set has no id");
  EXPECT_EQ(refusal([&] { config_.remove_configuration_set("default"); }),
            "the default configuration set cannot be removed");
  EXPECT_EQ(refusal([&] { config_.activate_configuration_set("other"); }), "no configuration set 'other'");
  SDOPackage::NVList change = nv_from({{"x", "y"}});
  CORBA::Object_var nothing = CORBA::Object::_nil();
  change[0].value <<= nothing.in();
  EXPECT_EQ(refusal([&] { config_.set_configuration_parameter("label", change[0].value); }),
            "label: the value must be a string, a number or a boolean");
  EXPECT_TRUE(applied_.empty());
  EXPECT_THROW(config_.declare({"bad", "x", number_between(0, 1), {}}), std::invalid_argument);
}

TEST_F(RtcUnit, ReturnCodeAndStateNames) {
  EXPECT_STREQ(return_code_name(RTC::PRECONDITION_NOT_MET), "PRECONDITION_NOT_MET");
  EXPECT_STREQ(state_name(RTC::ACTIVE), "Active");
  EXPECT_STREQ(state_name(RTC::ERROR), "Error");
}

TEST_F(RtcUnit, ConnectorIdsAreVersion4Uuids) {
  const std::regex uuid("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}");
  const std::string a = make_uuid();
  EXPECT_TRUE(std::regex_match(a, uuid)) << a;
  EXPECT_NE(a, make_uuid());
}

TEST_F(RtcUnit, EndpointFromAddress) {
  EXPECT_EQ(endpoint_from_address("127.0.0.1:2809", "--listen"), "giop:tcp:127.0.0.1:2809");
  EXPECT_THROW(endpoint_from_address("nonsense", "--listen"), util::ConfigError);
}

class ManagerConfigFile : public ::testing::Test {
 protected:
  void TearDown() override { std::filesystem::remove(path_); }
  ManagerConfig load(const std::string& text) {
    std::ofstream(path_) << text;
    return load_manager_config(path_);
  }
  std::string error_of(const std::string& text) {
    try {
      load(text);
    } catch (const util::ConfigError& e) {
      return e.what();
    }
    return "no error";
  }
  // One file per test process: ctest runs each test of this suite as a process of its own, side by side.
  const std::string path_ = ::testing::TempDir() + "/manager-config-" + std::to_string(::getpid()) + ".yaml";
};

// The calls in flight to one peer: 32 unless --max-calls-per-peer says otherwise, within 1..1024.
TEST(OrbFlags, CallsPerPeerReachTheOrbsOptionsWithinTheirRange) {
  OrbFlags flags;
  EXPECT_EQ(orb_options_from(flags, "").max_calls_per_peer, 32u);
  flags.max_calls_per_peer = 2;
  EXPECT_EQ(orb_options_from(flags, "").max_calls_per_peer, 2u);
  for (const unsigned refused : {0u, 1025u}) {
    flags.max_calls_per_peer = refused;
    try {
      orb_options_from(flags, "");
      ADD_FAILURE() << refused << " was accepted";
    } catch (const util::ConfigError& e) {
      EXPECT_EQ(std::string(e.what()), "--max-calls-per-peer: " + std::to_string(refused) + " is outside 1..1024");
    }
  }
}

TEST_F(ManagerConfigFile, ReadsComponentsWithDefaults) {
  const ManagerConfig config = load(
      "rate: 50\n"
      "components:\n"
      "  - type: Diagnostic\n"
      "  - type: Connector\n    instance: Connector7\n    rate: 5\n    activate: true\n"
      "    config:\n      poll_ms: 100\n");
  EXPECT_DOUBLE_EQ(config.rate_hz, 50.0);
  ASSERT_EQ(config.components.size(), 2u);
  EXPECT_EQ(config.components[0].type, "Diagnostic");
  EXPECT_TRUE(config.components[0].instance_name.empty());
  EXPECT_FALSE(config.components[0].activate);
  EXPECT_EQ(config.components[1].instance_name, "Connector7");
  EXPECT_DOUBLE_EQ(config.components[1].rate_hz, 5.0);
  EXPECT_TRUE(config.components[1].activate);
  EXPECT_EQ(config.components[1].config["poll_ms"].as<int>(), 100);
}

TEST_F(ManagerConfigFile, ReportsEveryErrorWithItsKey) {
  const std::string error = error_of(
      "rate: fast\n"
      "speed: 3\n"
      "components:\n"
      "  - instance: X\n"
      "  - type: Diagnostic\n    rate: 0\n    activate: maybe\n"
      "  - just a string\n");
  EXPECT_NE(error.find("has 6 error(s)"), std::string::npos) << error;
  for (const char* expected :
       {"rate: 'fast' is not a valid value", "speed: unknown key", "components[0].type: missing",
        "components[1].rate: 0 is not a positive rate", "components[1].activate", "components[2]: must be a map"}) {
    EXPECT_NE(error.find(expected), std::string::npos) << expected << " in " << error;
  }
  EXPECT_NE(error_of("components: 3\n").find("components: a list of components is required"), std::string::npos);
  EXPECT_NE(error_of("[1, 2]\n").find("must be a YAML map"), std::string::npos);
  std::filesystem::remove(path_);
  EXPECT_NE(error_of("").find("must be a YAML map"), std::string::npos);
}

}  // namespace
}  // namespace urs::rtc
