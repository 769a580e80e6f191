// urs-sam configuration: validated once, every error reported with its key and value.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>

#include "sam_config.hpp"
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
