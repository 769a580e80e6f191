#pragma once
// The RT side as real processes for integration tests: a real omniNames on a free port and
// urs-rtc-manager processes started from a YAML text, each waited for through its ready file.
// The test process gets its own ORB (one per process) and a naming client.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>

#include "RTC.hh"
#include "naming_service.hpp"
#include "process.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {

// The test process's ORB, created on first use and kept until exit.
inline rtc::Orb& test_orb() {
  static rtc::Orb orb(rtc::OrbOptions{"", std::chrono::milliseconds(5000), std::chrono::milliseconds(2000)});
  return orb;
}

// The minimal foreign route: connect() on a port with a profile naming only that port, as a
// client that has no port of its own does. The profile comes back with what the port published
// (a provider's IOR under both key styles); `code` is connect()'s answer.
inline RTC::ConnectorProfile connect_alone(RTC::PortService_ptr port, RTC::ReturnCode_t& code) {
  RTC::ConnectorProfile profile;
  profile.name = CORBA::string_dup("foreign");
  profile.connector_id = CORBA::string_dup("");
  profile.ports.length(1);
  profile.ports[0] = RTC::PortService::_duplicate(port);
  code = port->connect(profile);
  return profile;
}

// A component of type `type_name` with one consumer port "diagnostic" that requires
// URS::Diagnostic under the interface name `interface_name`.
class DiagnosticConsumer : public rtc::Component {
 public:
  DiagnosticConsumer(const std::string& type_name, const std::string& interface_name)
      : Component({type_name, "test consumer", "1.0", "URSLink", "Test"}),
        port_("diagnostic"),
        consumer_(port_.require(interface_name, "URS::Diagnostic")) {}
  RTC::PortService_ptr port() const { return port_.reference(); }
  rtc::Consumer& consumer() { return consumer_; }

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    add_port(port_);
    return RTC::RTC_OK;
  }

 private:
  rtc::CorbaPort port_;
  rtc::Consumer& consumer_;
};

class RtSpaceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("rt");
    naming_ = std::make_unique<NamingService>(dir_);
    client_ = std::make_unique<rtc::NamingClient>(test_orb(), naming_->address());
  }

  void TearDown() override {
    if (HasFailure()) {
      for (const auto& [name, process] : managers_) std::cerr << "---- " << name << " log\n" << process->log();
      std::cerr << "---- omniNames log\n" << naming_->log();
    }
    managers_.clear();
    client_.reset();
    naming_.reset();
    std::filesystem::remove_all(dir_);
  }

  // Starts a manager named `name` (its files are <dir>/<name>.*) on naming context `host`; returns
  // the naming paths it bound, one per line, or fails the test if it does not come up.
  std::string start_manager(const std::string& name, const std::string& host, const std::string& config_yaml,
                            const std::vector<std::string>& extra_args = {}) {
    const std::string config = dir_ + "/" + name + ".yaml";
    const std::string ready = dir_ + "/" + name + ".ready";
    std::ofstream(config) << config_yaml;
    std::filesystem::remove(ready);
    std::vector<std::string> argv{
        URS_RTC_MANAGER_BIN, "--space", "lab",          "--naming", naming_->address(), "--host", host,
        "--config",          config,    "--ready-file", ready,      "--log-level",      "debug"};
    argv.insert(argv.end(), extra_args.begin(), extra_args.end());
    managers_[name] = std::make_unique<Process>(argv, dir_ + "/" + name + ".log");
    Process& process = *managers_[name];
    const bool up =
        wait_until([&] { return std::filesystem::exists(ready) || !process.running(); }, std::chrono::seconds(20));
    EXPECT_TRUE(up && std::filesystem::exists(ready)) << name << " did not come up:\n" << process.log();
    return std::filesystem::exists(ready) ? read_text(ready) : std::string();
  }

  // The object the service port `port` of the component at `path` provides, got the way a
  // foreign client gets it: connect_alone(), then the old-style key "port.<type>.<name>". Adds a
  // test failure and returns nil if any step fails.
  CORBA::Object_ptr provided_object(const std::string& path, const std::string& port, const std::string& type,
                                    const std::string& interface_name) {
    auto rtc = resolve<RTC::RTObject>(path);
    RTC::PortService_var service_port = CORBA::is_nil(rtc) ? RTC::PortService::_nil() : rtc::find_port(rtc, port);
    if (CORBA::is_nil(service_port)) {
      ADD_FAILURE() << path << " has no port " << port;
      return CORBA::Object::_nil();
    }
    RTC::ReturnCode_t code = RTC::RTC_ERROR;
    const RTC::ConnectorProfile profile = connect_alone(service_port, code);
    const auto ior = rtc::nv_string(profile.properties, "port." + type + "." + interface_name);
    if (code != RTC::RTC_OK || !ior) {
      ADD_FAILURE() << path << ":" << port << " published no " << type << " " << interface_name;
      return CORBA::Object::_nil();
    }
    return test_orb().string_to_object(*ior);
  }

  Process& manager(const std::string& name) { return *managers_.at(name); }
  void forget_manager(const std::string& name) { managers_.erase(name); }

  template <typename T>
  typename T::_var_type resolve(const std::string& path) {
    CORBA::Object_var object = client_->resolve(path);
    return T::_narrow(object);
  }

  std::string dir_;
  std::unique_ptr<NamingService> naming_;
  std::unique_ptr<rtc::NamingClient> client_;
  std::map<std::string, std::unique_ptr<Process>> managers_;
};

}  // namespace urs::test
