// urs-sam configuration: validated once, every error reported with its key and value.

#include "sam_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>

#include "urs/util/cli.hpp"

namespace urs::sam {
namespace {

using ::testing::HasSubstr;

std::string write_temp(const std::string& text) {
  char path[] = "/tmp/urs-sam-config-XXXXXX";
  int fd = mkstemp(path);
  close(fd);
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const std::string& yaml) {
  auto path = write_temp(yaml);
  try {
    load_sam_config(path, {"diagnostic"}, "hostA");
  } catch (const util::ConfigError& e) {
    std::remove(path.c_str());
    return e.what();
  }
  std::remove(path.c_str());
  return "";
}

TEST(SamConfig, ParsesAgentsAndSubstitutesTheHost) {
  auto path = write_temp(
      "name: sam-lab\nworkers: 3\nagents:\n"
      "  - {name: 'diag-{host}', type: diagnostic, deadline_ms: 250, properties: {where: '{host}'}}\n");
  auto config = load_sam_config(path, {"diagnostic"}, "hostA");
  std::remove(path.c_str());
  EXPECT_EQ(config.name, "sam-lab");
  EXPECT_EQ(config.workers, 3u);
  ASSERT_EQ(config.agents.size(), 1u);
  EXPECT_EQ(config.agents[0].name, "diag-hostA");
  EXPECT_EQ(config.agents[0].deadline_ms, 250u);
  EXPECT_EQ(config.agents[0].properties.at("where"), "hostA");
}

TEST(SamConfig, DefaultNameIsSamAtHost) {
  auto path = write_temp("agents: [{name: d, type: diagnostic}]\n");
  EXPECT_EQ(load_sam_config(path, {"diagnostic"}, "hostA").name, "sam@hostA");
  std::remove(path.c_str());
}

TEST(SamConfig, ReportsEveryErrorWithItsKey) {
  auto error = error_of(
      "workers: 0\nbogus: 1\nagents:\n"
      "  - {name: a, type: laser}\n"
      "  - {name: a, type: diagnostic, colour: red}\n"
      "  - {type: diagnostic}\n");
  EXPECT_THAT(error, HasSubstr("workers: 0 is outside 1..256"));
  EXPECT_THAT(error, HasSubstr("bogus: unknown key"));
  EXPECT_THAT(error, HasSubstr("agents[0].type: unknown agent type 'laser' (known: diagnostic)"));
  EXPECT_THAT(error, HasSubstr("agents[1].name: 'a' is used by another agent"));
  EXPECT_THAT(error, HasSubstr("agents[1].colour: unknown key"));
  EXPECT_THAT(error, HasSubstr("agents[2].name: missing"));
}

TEST(SamConfig, EmptyAgentListAndBadYamlAreRefused) {
  EXPECT_THAT(error_of("agents: []\n"), HasSubstr("agents: a non-empty list of agents is required"));
  EXPECT_THAT(error_of("agents: [\n"), HasSubstr("is not valid YAML"));
}

TEST(SamConfig, PluginsAreHandedToTheLoaderBeforeTypesAreChecked) {
  auto path = write_temp(
      "plugins: [calc, /opt/x/libgrip.so]\nplugin_path: [/tmp]\n"
      "agents: [{name: c, type: calculator, params: {label: l}}]\n");
  std::vector<std::string> seen;
  auto config = load_sam_config(path, "h", [&seen](const SamConfig& partial) {
    seen = partial.plugins;
    seen.insert(seen.end(), partial.plugin_path.begin(), partial.plugin_path.end());
    return AgentTypes{{"diagnostic", "calculator"}, {}};
  });
  std::remove(path.c_str());
  EXPECT_EQ(seen, (std::vector<std::string>{"calc", "/opt/x/libgrip.so", "/tmp"}));
  ASSERT_EQ(config.agents.size(), 1u);
  EXPECT_EQ(config.agents[0].type, "calculator");
  EXPECT_EQ(config.agents[0].params["label"].as<std::string>(), "l");
}

TEST(SamConfig, BadPluginKeysAreReportedWithTheOtherErrors) {
  auto error = error_of(
      "plugins: calc\nplugin_path: [/tmp, /nonexistent-folder]\n"
      "agents: [{name: a, type: laser}]\n");
  EXPECT_THAT(error, HasSubstr("plugins: must be a list of strings"));
  EXPECT_THAT(error, HasSubstr("plugin_path[1]: '/nonexistent-folder' is not a folder"));
  EXPECT_THAT(error, HasSubstr("agents[0].type: unknown agent type 'laser'"));
  EXPECT_THAT(error_of("plugins: [[a]]\nagents: [{name: d, type: diagnostic}]\n"),
              HasSubstr("plugins[0]: must be a string"));
  EXPECT_THAT(error_of("plugin_path: ['']\nagents: [{name: d, type: diagnostic}]\n"),
              HasSubstr("plugin_path[0]: must not be empty"));
}

TEST(SamConfig, AnUnknownTypeIsDroppedNotFatalOnceAPluginWasRefused) {
  auto path = write_temp("plugins: [bad]\nagents: [{name: d, type: diagnostic}, {name: g, type: ghost}]\n");
  auto config = load_sam_config(path, "h", [](const SamConfig&) {
    return AgentTypes{{"diagnostic"}, {"/opt/bad.so"}};
  });
  std::remove(path.c_str());
  ASSERT_EQ(config.agents.size(), 1u);
  EXPECT_EQ(config.agents[0].name, "d");
}

TEST(SamConfig, MissingFileIsNamed) {
  try {
    load_sam_config("/nonexistent/sam.yaml", {"diagnostic"}, "h");
    FAIL();
  } catch (const util::ConfigError& e) {
    EXPECT_STREQ(e.what(), "--config: cannot read '/nonexistent/sam.yaml'");
  }
}

}  // namespace
}  // namespace urs::sam
