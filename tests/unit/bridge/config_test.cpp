// urs-bridge configuration: what it accepts, its defaults, and every error named with its key.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "urs/bridge/config.hpp"
#include "urs/util/cli.hpp"

namespace urs::bridge {
namespace {

class BridgeConfigTest : public ::testing::Test {
 protected:
  BridgeConfig load(const std::string& yaml) {
    std::ofstream(path_) << yaml;
    return load_bridge_config(path_, "host1");
  }
  // The error message of a configuration that must be refused.
  std::string refused(const std::string& yaml) {
    try {
      load(yaml);
    } catch (const util::ConfigError& e) {
      return e.what();
    }
    ADD_FAILURE() << "accepted:\n" << yaml;
    return "";
  }
  void TearDown() override { std::filesystem::remove(path_); }

  const std::string path_ = ::testing::TempDir() + "bridge-config-" + std::to_string(getpid()) + ".yaml";
};

TEST_F(BridgeConfigTest, DefaultsWithoutDds) {
  const BridgeConfig config = load("name: b\n");
  EXPECT_EQ(config.name, "b");
  EXPECT_FALSE(config.dds.enabled);
  EXPECT_TRUE(config.dds.state.components);
  EXPECT_FALSE(config.dds.state.poses);
  EXPECT_TRUE(config.dds.state.events.empty());
  EXPECT_TRUE(config.dds.state.context_allow.empty());
  EXPECT_EQ(load("{}\n").name, "bridge@host1");
}

TEST_F(BridgeConfigTest, SharedStateAndDiscoveryServer) {
  const BridgeConfig config = load(
      "dds:\n"
      "  domain: 3\n"
      "  discovery: {servers: [\"site-a:11811\", \"10.0.0.2:11812\"]}\n"
      "  state:\n"
      "    components: false\n"
      "    period_ms: 250\n"
      "    poses: {domain: 4, source: ground_truth, robots: [r1, r2], period_ms: 50}\n"
      "    events: [\"robot1/#\"]\n"
      "    context: {allow: [\"room.*\"], deny: [\"room.secret\"]}\n"
      "    import: false\n");
  const DdsConfig& dds = config.dds;
  EXPECT_TRUE(dds.enabled);
  EXPECT_EQ(dds.link.discovery_servers, (std::vector<std::string>{"site-a:11811", "10.0.0.2:11812"}));
  EXPECT_TRUE(dds.link.discovery_listen.empty());
  EXPECT_FALSE(dds.state.components);
  EXPECT_EQ(dds.state.period.count(), 250);
  ASSERT_TRUE(dds.state.poses);
  EXPECT_EQ(dds.state.poses->domain, 4u);
  EXPECT_TRUE(dds.state.poses->ground_truth);
  EXPECT_EQ(dds.state.poses->robots, (std::vector<std::string>{"r1", "r2"}));
  EXPECT_EQ(dds.state.poses->period.count(), 50);
  EXPECT_EQ(dds.state.events, std::vector<std::string>{"robot1/#"});
  EXPECT_TRUE(allowed("room.temperature", dds.state.context_allow, dds.state.context_deny));
  EXPECT_FALSE(allowed("room.secret", dds.state.context_allow, dds.state.context_deny));
  EXPECT_FALSE(dds.state.import);

  const BridgeConfig server = load("dds: {discovery: {listen: \"0.0.0.0:11811\", id: 2}}\n");
  EXPECT_EQ(server.dds.link.discovery_listen, "0.0.0.0:11811");
  EXPECT_EQ(server.dds.link.discovery_server_id, 2u);
}

TEST_F(BridgeConfigTest, EveryStateAndDiscoveryErrorIsNamedWithItsKey) {
  const std::string message = refused(
      "dds:\n"
      "  domain: 1\n"
      "  discovery: {servers: [\"no-port\", \"host:99999\"], id: 300, extra: 1}\n"
      "  state:\n"
      "    period_ms: 5\n"
      "    poses: {domain: 1, source: sonar}\n"
      "    colour: blue\n");
  for (const char* expected : {
           "dds.discovery.servers[0]: 'no-port' is not HOST:PORT",
           "dds.discovery.servers[1]: 'host:99999' is not HOST:PORT",
           "dds.discovery.id: 300 is outside 0..255",
           "dds.discovery.extra",
           "dds.state.period_ms: 5 is outside 10..60000",
           "dds.state.poses.domain: 1 is the link's domain; give the devices their own",
           "dds.state.poses.source: 'sonar' is neither localizer nor ground_truth",
           "dds.state.poses.robots: name at least one robot",
           "dds.state.colour",
       }) {
    EXPECT_NE(message.find(expected), std::string::npos) << "missing \"" << expected << "\" in:\n" << message;
  }
  EXPECT_NE(refused("dds: {discovery: {}}\n").find("dds.discovery: give 'listen' (be the server) or 'servers'"),
            std::string::npos);
  EXPECT_NE(refused("dds: {state: {poses: {robots: [r]}}}\n").find("dds.state.poses.domain: missing"),
            std::string::npos);
}

// DDS-Security: deploy/pki.sh's folder, or the files by name (a named file overriding the folder's);
// one of the two, with a certificate, is required; unknown keys are named.
TEST_F(BridgeConfigTest, SecurityTakesThePkiFolderOrTheFiles) {
  const BridgeConfig folder = load("dds: {security: {pki: /run/secrets/federation, crl: /etc/urs/crl.pem}}\n");
  EXPECT_EQ(folder.dds.security_pki, "/run/secrets/federation");
  EXPECT_EQ(folder.dds.link.security.crl, "/etc/urs/crl.pem");
  EXPECT_FALSE(folder.dds.link.security.enabled());  // until the bridge fills it from the folder

  const BridgeConfig files = load("dds: {security: {identity_ca: ca.pem, certificate: kr.pem, private_key: kr.key,\n"
                                  "                  governance: g.p7s, permissions: p.p7s}}\n");
  EXPECT_TRUE(files.dds.link.security.enabled());
  EXPECT_EQ(files.dds.link.security.documents_ca(), "ca.pem");

  EXPECT_FALSE(load("dds: {domain: 3}\n").dds.link.security.enabled());
  EXPECT_NE(refused("dds: {security: {}}\n").find("dds.security: give 'pki'"), std::string::npos);
  EXPECT_NE(refused("dds: {security: {pki: x, password: y}}\n").find("dds.security.password"), std::string::npos);
  EXPECT_NE(refused("dds: {discovery: {servers: [\"a:11811\"]}, security: {pki: x}}\n")
                .find("dds.security: cannot be combined with dds.discovery"),
            std::string::npos);
}

// dds.export.callers: service globs in the order written, each with its callers (SPACE or
// SPACE/NAME); trust_declared_space only with callers and never on a secured link; dds.audit's
// file is taken from the configuration's folder, which must exist.
TEST_F(BridgeConfigTest, CallersAndAuditAreReadInOrderWithEveryErrorNamed) {
  const DdsConfig dds = load("dds:\n"
                             "  export:\n"
                             "    callers:\n"
                             "      \"rt.Secret*\": []\n"
                             "      \"rt.Diagnostic*\": [kr, \"jp/dds:jp\"]\n"
                             "      \"*\": [\"*\"]\n"
                             "    trust_declared_space: true\n"
                             "  audit: {file: calls.jsonl, max_bytes: 4096, files: 2}\n")
                            .dds;
  EXPECT_TRUE(dds.callers.enabled);
  EXPECT_TRUE(dds.callers.trust_declared_space);
  ASSERT_EQ(dds.callers.rules.size(), 3u);
  EXPECT_EQ(dds.callers.rules[0].services, "rt.Secret*");
  EXPECT_TRUE(dds.callers.rules[0].callers.empty());
  EXPECT_EQ(dds.callers.rules[1].services, "rt.Diagnostic*");
  EXPECT_EQ(dds.callers.rules[1].callers, (std::vector<std::string>{"kr", "jp/dds:jp"}));
  EXPECT_EQ(dds.callers.rules[2].services, "*");
  EXPECT_EQ(dds.audit.file, (std::filesystem::path(path_).parent_path() / "calls.jsonl").lexically_normal().string());
  EXPECT_EQ(dds.audit.max_bytes, 4096u);
  EXPECT_EQ(dds.audit.files, 2u);

  const DdsConfig defaults = load("dds: {domain: 3}\n").dds;
  EXPECT_FALSE(defaults.callers.enabled);
  EXPECT_FALSE(defaults.callers.trust_declared_space);
  EXPECT_TRUE(defaults.audit.file.empty());

  const std::string message = refused(
      "dds:\n"
      "  export:\n"
      "    callers:\n"
      "      \"rt.A*\": [\"\", \"a/b/c\", \"/x\", \"kr/\", \"k r\"]\n"
      "      \"rt.B*\": kr\n"
      "    colour: blue\n"
      "  audit: {file: /no/such/folder/calls.jsonl, max_bytes: 10, files: 0, rotate: daily}\n");
  for (const char* expected : {
           "dds.export.callers['rt.A*'][0]: is empty",
           "dds.export.callers['rt.A*'][1]: 'a/b/c' has more than one '/'",
           "dds.export.callers['rt.A*'][2]: '/x' names no space before '/'",
           "dds.export.callers['rt.A*'][3]: 'kr/' names no caller after '/'",
           "dds.export.callers['rt.A*'][4]: 'k r' contains white space",
           "dds.export.callers['rt.B*']: a list of callers (SPACE or SPACE/NAME) is expected",
           "dds.export.colour",
           "dds.audit.file: the folder /no/such/folder does not exist",
           "dds.audit.max_bytes: 10 is outside 1024..2^40",
           "dds.audit.files: 0 is outside 1..1000",
           "dds.audit.rotate",
       }) {
    EXPECT_NE(message.find(expected), std::string::npos) << "missing \"" << expected << "\" in:\n" << message;
  }
  EXPECT_NE(refused("dds: {export: {callers: [kr]}}\n").find("dds.export.callers: a map of service globs"),
            std::string::npos);
  EXPECT_NE(refused("dds: {audit: {}}\n").find("dds.audit.file: missing"), std::string::npos);
  EXPECT_NE(refused("dds: {export: {trust_declared_space: true}}\n")
                .find("dds.export.trust_declared_space: has no effect without dds.export.callers"),
            std::string::npos);
  EXPECT_NE(refused("dds: {security: {pki: x}, export: {callers: {\"*\": [kr]}, trust_declared_space: true}}\n")
                .find("dds.export.trust_declared_space: a secured link proves each caller's space"),
            std::string::npos);
}

// The participant lease: 20 s by default (no shorter than other vendors' own leases, so that a
// pause shorter than it drops nobody), never below the liveliness lease, within 100..600000 ms.
TEST_F(BridgeConfigTest, ParticipantLeaseDefaultsLongAndIsNeverBelowTheLease) {
  const DdsConfig defaults = load("dds: {domain: 3}\n").dds;
  EXPECT_EQ(defaults.link.lease.count(), 3000);
  EXPECT_EQ(defaults.link.participant_lease.count(), 20000);
  EXPECT_EQ(load("dds: {lease_ms: 1500}\n").dds.link.participant_lease.count(), 20000);
  EXPECT_EQ(load("dds: {lease_ms: 30000}\n").dds.link.participant_lease.count(), 30000);  // follows a longer lease
  EXPECT_EQ(load("dds: {participant_lease_ms: 5000}\n").dds.link.participant_lease.count(), 5000);
  EXPECT_EQ(load("dds: {lease_ms: 5000, participant_lease_ms: 5000}\n").dds.link.participant_lease.count(), 5000);

  EXPECT_NE(refused("dds: {lease_ms: 5000, participant_lease_ms: 4000}\n")
                .find("dds.participant_lease_ms: 4000 is below dds.lease_ms 5000"),
            std::string::npos);
  EXPECT_NE(refused("dds: {participant_lease_ms: 50}\n").find("dds.participant_lease_ms: 50 is outside 100..600000"),
            std::string::npos);
  EXPECT_NE(refused("dds: {participant_lease_ms: 700000}\n")
                .find("dds.participant_lease_ms: 700000 is outside 100..600000"),
            std::string::npos);
  EXPECT_NE(refused("dds: {participant_lease_ms: soon}\n").find("dds.participant_lease_ms"), std::string::npos);
}

}  // namespace
}  // namespace urs::bridge
