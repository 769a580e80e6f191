// urs::agent::load_plugins() against real shared libraries: the example's Calculator plug-in is
// loaded and its agent serves calls; each bad plug-in is refused with its path and the reason,
// and never stops the others from loading.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "urs/agent/plugin.hpp"

namespace {

using testing::HasSubstr;
using urs::agent::load_plugins;

const std::string kDir = URS_TEST_PLUGIN_DIR;

std::string library(const std::string& name) { return kDir + "/lib" + name + ".so"; }

TEST(PluginLoader, LoadsTheCalculatorAndBuildsItsAgentFromParams) {
  auto result = load_plugins({library("test_calculator_plugin")}, {}, {"diagnostic"});
  ASSERT_TRUE(result.refusals.empty()) << result.refusals[0].reason;
  ASSERT_EQ(result.agents.size(), 1u);
  const auto& loaded = result.agents[0];
  EXPECT_EQ(loaded.agent.type, "calculator");
  EXPECT_EQ(loaded.agent.component_type, "Calculator");
  EXPECT_EQ(loaded.plugin, library("test_calculator_plugin"));
  auto agent = loaded.agent.make(YAML::Load("{label: lab}"));
  ASSERT_NE(agent, nullptr);
  const auto& interface = agent->interface();
  EXPECT_EQ(interface.full_name(), "PluginExample.Calculator");
  EXPECT_NE(interface.FindMethodByName("divide"), nullptr);
}

TEST(PluginLoader, FindsANameInTheSearchPathAndInUrsPluginPath) {
  auto by_path = load_plugins({"test_calculator_plugin"}, {"/nonexistent", kDir}, {});
  ASSERT_EQ(by_path.loaded.size(), 1u);
  EXPECT_EQ(by_path.loaded[0], library("test_calculator_plugin"));

  ::setenv("URS_PLUGIN_PATH", ("/nonexistent::" + kDir).c_str(), 1);
  const auto search = urs::agent::plugin_search_path({"/first"});
  ::unsetenv("URS_PLUGIN_PATH");
  EXPECT_EQ(search, (std::vector<std::string>{"/first", "/nonexistent", kDir}));
}

// Each refusal names the path and the reason; the good plug-in after it still loads.
void expect_refused(const std::string& entry, const std::string& path, const std::string& reason) {
  auto result = load_plugins({entry, library("test_calculator_plugin")}, {kDir}, {});
  ASSERT_EQ(result.refusals.size(), 1u) << entry;
  EXPECT_EQ(result.refusals[0].path, path);
  EXPECT_THAT(result.refusals[0].reason, HasSubstr(reason));
  ASSERT_EQ(result.agents.size(), 1u) << entry;
  EXPECT_EQ(result.agents[0].agent.type, "calculator");
}

TEST(PluginLoader, RefusesAMissingFile) {
  expect_refused("/nonexistent/libnothing.so", "/nonexistent/libnothing.so", "no such file");
  expect_refused("nothing", "nothing",
                 "not found as nothing or libnothing.so in the plug-in search path (" + kDir + ")");
}

TEST(PluginLoader, RefusesAFileThatIsNotASharedLibrary) {
  expect_refused(kDir + "/cmake_install.cmake", kDir + "/cmake_install.cmake", "cannot be loaded: ");
}

TEST(PluginLoader, RefusesALibraryWithoutTheSymbols) {
  expect_refused(library("test_plugin_no_symbol"), library("test_plugin_no_symbol"), "no symbol urs_plugin_abi");
}

TEST(PluginLoader, RefusesAnotherAbiVersion) {
  expect_refused(library("test_plugin_wrong_abi"), library("test_plugin_wrong_abi"),
                 "built for plug-in ABI version " + std::to_string(urs::agent::kPluginAbiVersion + 1000) +
                     ", this program loads version " + std::to_string(urs::agent::kPluginAbiVersion));
}

TEST(PluginLoader, RefusesAPluginThatRegistersNothing) {
  expect_refused(library("test_plugin_registers_nothing"), library("test_plugin_registers_nothing"),
                 "registers no agent type");
}

TEST(PluginLoader, RefusesAFailedRegistrationAndDropsWhatItAdded) {
  expect_refused(library("test_plugin_fails"), library("test_plugin_fails"), "urs_plugin_register returned 3");
}

TEST(PluginLoader, RefusesATypeTheHostAlreadyHas) {
  auto result = load_plugins({library("test_plugin_throws")}, {}, {"diagnostic"});
  ASSERT_EQ(result.refusals.size(), 1u);
  EXPECT_THAT(result.refusals[0].reason,
              HasSubstr("urs_plugin_register failed: agent type 'diagnostic' is built into this program"));
  EXPECT_TRUE(result.agents.empty());
}

TEST(PluginLoader, RefusesTheSameTypeFromASecondPlugin) {
  auto result = load_plugins({library("test_calculator_plugin"), library("test_calculator_plugin")}, {}, {});
  ASSERT_EQ(result.agents.size(), 1u);
  ASSERT_EQ(result.refusals.size(), 1u);
  EXPECT_THAT(result.refusals[0].reason, HasSubstr("agent type 'calculator' is already defined by the plug-in " +
                                                   library("test_calculator_plugin")));
}

}  // namespace
