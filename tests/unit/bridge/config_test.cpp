// urs-bridge configuration: what it accepts, its defaults, and every error named with its key.

#include "urs/bridge/config.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

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

TEST_F(BridgeConfigTest, TheHostsQueueIsBoundedAndTheRegistryPollIsAFallback) {
  const BridgeConfig defaults = load("name: b\n");
  EXPECT_EQ(defaults.queue, 1024u);
  EXPECT_EQ(defaults.camus_poll, std::chrono::milliseconds(10000));
  EXPECT_EQ(load("queue: 0\n").queue, 0u);  // no limit
  EXPECT_NE(refused("queue: 2000000\n").find("queue: 2000000 is outside 0..1000000"), std::string::npos);
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

// The link over TCP (docs/sites.md): a listening site with the public address it announces, a
// site connecting out to it, the discovery server on the listening port.
TEST_F(BridgeConfigTest, TheLinkOverTcpListensOrConnects) {
  using Transport = federation::DdsOptions::Transport;
  EXPECT_EQ(load("dds: {domain: 3}\n").dds.link.transport, Transport::kUdp);
  EXPECT_EQ(load("dds: {transport: udp}\n").dds.link.transport, Transport::kUdp);

  const BridgeConfig listening = load("dds: {transport: tcp, tcp: {listen: 7400, public: \"198.51.100.2\"}}\n");
  EXPECT_EQ(listening.dds.link.transport, Transport::kTcp);
  EXPECT_EQ(listening.dds.link.tcp.listen, 7400);
  EXPECT_EQ(listening.dds.link.tcp.public_address, "198.51.100.2");
  EXPECT_EQ(listening.dds.link.tcp.public_port, 0);  // the listening port
  EXPECT_TRUE(listening.dds.link.tcp.connect.empty());

  const BridgeConfig forwarded = load("dds: {transport: tcp, tcp: {listen: 7400, public: \"198.51.100.2:443\"}}\n");
  EXPECT_EQ(forwarded.dds.link.tcp.public_address, "198.51.100.2");
  EXPECT_EQ(forwarded.dds.link.tcp.public_port, 443);

  const BridgeConfig connecting =
      load("dds: {transport: tcp, tcp: {connect: [\"site-a.example:7400\", \"10.0.0.2:443\"]}}\n");
  EXPECT_EQ(connecting.dds.link.tcp.listen, 0);
  EXPECT_EQ(connecting.dds.link.tcp.connect, (std::vector<std::string>{"site-a.example:7400", "10.0.0.2:443"}));
  EXPECT_TRUE(connecting.dds.link.tcp.public_address.empty());
  EXPECT_EQ(connecting.dds.rejoin_unmet, std::chrono::seconds(20));
  EXPECT_EQ(load("dds: {transport: tcp, tcp: {connect: [\"a:7400\"], rejoin_after_ms: 0}}\n").dds.rejoin_unmet,
            std::chrono::milliseconds(0));
  EXPECT_EQ(
      load("dds: {transport: tcp, tcp: {connect: [\"a:7400\"], public: 192.168.10.2}}\n").dds.link.tcp.public_address,
      "192.168.10.2");

  const BridgeConfig server =
      load("dds: {transport: tcp, tcp: {listen: 7400, public: 198.51.100.2}, discovery: {listen: \"0.0.0.0:7400\"}}\n");
  EXPECT_EQ(server.dds.link.discovery_listen, "0.0.0.0:7400");
  const BridgeConfig client = load("dds: {transport: tcp, discovery: {servers: [\"198.51.100.2:7400\"]}}\n");
  EXPECT_EQ(client.dds.link.discovery_servers, std::vector<std::string>{"198.51.100.2:7400"});
}

// dds.interfaces: the link kept to chosen interfaces of this host (loopback is on every host).
TEST_F(BridgeConfigTest, TheLinkKeepsToTheInterfacesNamedByTheirAddresses) {
  EXPECT_TRUE(load("dds: {domain: 3}\n").dds.link.interfaces.empty());  // every interface
  EXPECT_EQ(load("dds: {interfaces: [127.0.0.1]}\n").dds.link.interfaces, std::vector<std::string>{"127.0.0.1"});
  EXPECT_EQ(load("dds: {transport: tcp, tcp: {connect: [\"127.0.0.1:7400\"]}, interfaces: [127.0.0.1]}\n")
                .dds.link.interfaces,
            std::vector<std::string>{"127.0.0.1"});

  const std::string message = refused("dds: {interfaces: [lo, 0.0.0.0, 203.0.113.254, 127.0.0.1, 300.1.1.1]}\n");
  for (const char* expected : {
           "dds.interfaces[0]: 'lo' is not an IPv4 address (Fast DDS 2.9 takes an interface's address, not its name)",
           "dds.interfaces[1]: '0.0.0.0' is no interface's address: leave dds.interfaces out to use every interface",
           "dds.interfaces[2]: '203.0.113.254' is no address of this host's interfaces (",
           "dds.interfaces[4]: '300.1.1.1' is not an IPv4 address",
       }) {
    EXPECT_NE(message.find(expected), std::string::npos) << "missing \"" << expected << "\" in:\n" << message;
  }
  EXPECT_EQ(message.find("dds.interfaces[3]"), std::string::npos) << message;  // loopback is this host's
  EXPECT_NE(message.find("127.0.0.1"), std::string::npos) << message;          // listed among the host's
  EXPECT_NE(refused("dds: {interfaces: []}\n")
                .find("dds.interfaces: name at least one address, or leave the key out to use every interface"),
            std::string::npos);
  EXPECT_NE(refused("dds: {interfaces: 127.0.0.1}\n").find("dds.interfaces: a list is expected"), std::string::npos);
}

TEST_F(BridgeConfigTest, EveryTcpErrorIsNamedWithItsKey) {
  const std::string message = refused(
      "dds:\n"
      "  transport: tcp\n"
      "  udp_only: true\n"
      "  initial_peers: [a]\n"
      "  tcp: {listen: 7400, connect: [\"no-port\", \"a:70000\"], colour: blue}\n");
  for (const char* expected : {
           "dds.udp_only: has no effect with dds.transport: tcp",
           "dds.initial_peers: UDP only; over TCP the listening sites are dds.tcp.connect",
           "dds.tcp.connect[0]: 'no-port' is not HOST:PORT",
           "dds.tcp.connect[1]: 'a:70000' is not HOST:PORT",
           "dds.tcp.colour",
           "dds.tcp.public: missing: a listening site must announce the address",
       }) {
    EXPECT_NE(message.find(expected), std::string::npos) << "missing \"" << expected << "\" in:\n" << message;
  }
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {connect: [\"a:7400\"], rejoin_after_ms: 500}}\n")
                .find("dds.tcp.rejoin_after_ms: 500 is neither 0 nor in 1000..3600000"),
            std::string::npos);
  EXPECT_NE(refused("dds: {transport: quic}\n").find("dds.transport: 'quic' is neither udp nor tcp"),
            std::string::npos);
  EXPECT_NE(refused("dds: {tcp: {listen: 7400}}\n").find("dds.tcp: only with dds.transport: tcp"), std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp}\n").find("dds.tcp: missing: give 'listen'"), std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {}}\n").find("dds.tcp: give 'listen' (this site listens) or 'connect'"),
            std::string::npos);
  EXPECT_NE(
      refused("dds: {transport: tcp, tcp: {listen: 0, public: 1.2.3.4}}\n").find("dds.tcp.listen: must be a port"),
      std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {listen: 7400, public: site-a.example}}\n")
                .find("dds.tcp.public: 'site-a.example' is not IPv4[:PORT]"),
            std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {listen: 7400, public: \"1.2.3.4:0\"}}\n")
                .find("dds.tcp.public: '1.2.3.4:0' is not IPv4[:PORT]"),
            std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {connect: [\"a:7400\"], public: \"1.2.3.4:7400\"}}\n")
                .find("dds.tcp.public: a site that does not listen announces an address only"),
            std::string::npos);
  EXPECT_NE(
      refused("dds: {transport: tcp, tcp: {listen: 7400, public: 1.2.3.4}, discovery: {listen: \"0.0.0.0:11811\"}}\n")
          .find("dds.discovery.listen: over TCP the discovery server listens on the link's port (dds.tcp.listen "
                "7400), not on 11811"),
      std::string::npos);
  EXPECT_NE(refused("dds: {transport: tcp, tcp: {listen: 7400, public: 1.2.3.4}, discovery: {servers: [\"a:7400\"]},\n"
                    "      security: {pki: x}}\n")
                .find("dds.security: cannot be combined with dds.discovery"),
            std::string::npos);
}

// DDS-Security: deploy/pki.sh's folder, or the files by name (a named file overriding the folder's);
// one of the two, with a certificate, is required; unknown keys are named.
TEST_F(BridgeConfigTest, SecurityTakesThePkiFolderOrTheFiles) {
  const BridgeConfig folder = load("dds: {security: {pki: /run/secrets/federation, crl: /etc/urs/crl.pem}}\n");
  EXPECT_EQ(folder.dds.security_pki, "/run/secrets/federation");
  EXPECT_EQ(folder.dds.link.security.crl, "/etc/urs/crl.pem");
  EXPECT_FALSE(folder.dds.link.security.enabled());  // until the bridge fills it from the folder

  const BridgeConfig files = load(
      "dds: {security: {identity_ca: ca.pem, certificate: kr.pem, private_key: kr.key,\n"
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
  const DdsConfig dds = load(
                            "dds:\n"
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
  EXPECT_NE(
      refused("dds: {participant_lease_ms: 700000}\n").find("dds.participant_lease_ms: 700000 is outside 100..600000"),
      std::string::npos);
  EXPECT_NE(refused("dds: {participant_lease_ms: soon}\n").find("dds.participant_lease_ms"), std::string::npos);
}

// How long a lost space's services stay, unreachable: 30 s by default, 0 (none) up to an hour.
TEST_F(BridgeConfigTest, ALostSpacesServicesAreHeldThirtySecondsUnlessConfigured) {
  EXPECT_EQ(load("dds: {domain: 3}\n").dds.hold_lost.count(), 30000);
  EXPECT_EQ(load("dds: {hold_lost_ms: 0}\n").dds.hold_lost.count(), 0);
  EXPECT_EQ(load("dds: {hold_lost_ms: 3600000}\n").dds.hold_lost.count(), 3600000);
  EXPECT_NE(refused("dds: {hold_lost_ms: -1}\n").find("dds.hold_lost_ms: -1 is outside 0..3600000"), std::string::npos);
  EXPECT_NE(refused("dds: {hold_lost_ms: 3600001}\n").find("dds.hold_lost_ms: 3600001 is outside 0..3600000"),
            std::string::npos);
  EXPECT_NE(refused("dds: {hold_lost_ms: later}\n").find("dds.hold_lost_ms"), std::string::npos);
}

}  // namespace
}  // namespace urs::bridge
