// The secured DDS link (DDS-Security with Fast DDS's builtin plugins) on real participants, UDP
// only, with a PKI made by deploy/pki.sh: members of the federation see and call each other; a
// participant without security, or with a certificate of another CA claiming a member's name,
// sees nothing and reaches no one; a member calls only the spaces its permissions grant; and a
// bad file is refused before Fast DDS is asked, naming the file and what is wrong.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <set>
#include <thread>

#include "certificates.hpp"
#include "dds_domain.hpp"
#include "process.hpp"
#include "urs/bridge/dds_link.hpp"
#include "urs/bridge/dds_security.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

// The federation "fed" (kr calls jp and jp calls kr; member xx may call no one) and a rogue CA
// that issued its own "jp"; made once for the whole test program.
class SecuredLink : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(make_temp_dir("dds-security"));
    const std::string fed = *dir_ + "/fed";
    const std::string rogue = *dir_ + "/rogue";
    ASSERT_NO_THROW(run_pki({{"init", fed},
                             {"governance", fed},
                             {"member", fed, "kr", "--calls", "jp"},
                             {"member", fed, "jp", "--calls", "kr"},
                             {"member", fed, "xx"},
                             {"init", rogue},
                             {"governance", rogue},
                             {"member", rogue, "jp", "--calls", "kr"}}));
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*dir_);
    delete dir_;
  }

  static bridge::DdsSecurity member(const std::string& pki_dir, const std::string& space) {
    return bridge::security_from_folder(*dir_ + "/" + pki_dir, space);
  }

  static bridge::DdsOptions options(uint32_t domain, const std::string& space, bridge::DdsSecurity security) {
    bridge::DdsOptions o;
    o.domain = domain;
    o.space = space;
    o.bridge = "bridge-" + space;
    o.lease = 1500ms;
    o.udp_only = true;
    o.security = std::move(security);
    return o;
  }

  // Space kr's bridge in a process of its own, on the secured link: offers "svc" and answers every
  // call with its payload (from another thread than the DDS listener's, as DdsLink asks).
  // Forked before this process makes any DDS entity or thread.
  void serve_kr(uint32_t domain) {
    const pid_t child = fork();
    if (child != 0) {
      children_.push_back(child);
      return;
    }
    try {
      bridge::DdsLink link(options(domain, "kr", member("fed", "kr")), [] {},
                           [](call::Request request, call::Responder responder) {
                             responder.reply(call::Reply::success("kr heard " + request.payload + " from " +
                                                                  request.caller.space + " (" +
                                                                  request.caller.role + ")"));
                           });
      bridge::ServiceEntry entry;
      entry.name = "svc";
      entry.interface_name = "URS.Diagnostic";
      entry.descriptor_set = "a description";
      link.announce(entry);
      while (true) pause();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "kr: %s\n", e.what());
    }
    _exit(1);
  }

  static std::set<std::string> seen(const bridge::DdsLink& link) {
    std::set<std::string> found;
    for (const auto& entry : link.catalog()) found.insert(entry.space + "/" + entry.name);
    return found;
  }

  void TearDown() override {
    for (pid_t pid : children_) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }

  static std::string* dir_;
  std::vector<pid_t> children_;
};
std::string* SecuredLink::dir_ = nullptr;

auto no_calls = [](call::Request, call::Responder) {};

TEST_F(SecuredLink, MembersSeeAndCallEachOther) {
  const DdsDomains domains;
  serve_kr(domains[0]);
  bridge::DdsLink jp(options(domains[0], "jp", member("fed", "jp")), [] {}, no_calls);
  ASSERT_TRUE(wait_until([&] { return seen(jp).count("kr/svc") == 1; }, 30s)) << "jp never saw kr's service";
  const auto reply = jp.call("kr", "svc", "echo", "marker-7f3a", 10s);
  ASSERT_TRUE(reply.ok()) << call::status_name(reply.status) << ": " << reply.message;
  // The caller's space as jp's certificate proves it (role "member"), not only as declared.
  EXPECT_EQ(reply.payload, "kr heard marker-7f3a from jp (member)");
}

// While member jp sees kr and calls it, a participant without security and one whose certificate
// comes from another CA (claiming to be jp) see nothing of kr and reach no one.
TEST_F(SecuredLink, NoOneOutsideTheFederationJoins) {
  const DdsDomains domains;
  serve_kr(domains[0]);
  bridge::DdsLink plain(options(domains[0], "intruder", {}), [] {}, no_calls);
  bridge::DdsLink rogue(options(domains[0], "jp", member("rogue", "jp")), [] {}, no_calls);
  bridge::DdsLink jp(options(domains[0], "jp", member("fed", "jp")), [] {}, no_calls);
  ASSERT_TRUE(wait_until([&] { return seen(jp).count("kr/svc") == 1; }, 30s)) << "jp never saw kr's service";
  ASSERT_TRUE(jp.call("kr", "svc", "echo", "member", 10s).ok());
  // Everything kr sent reached jp by now; the others had the same chances.
  EXPECT_TRUE(seen(plain).empty()) << ::testing::PrintToString(seen(plain));
  EXPECT_TRUE(seen(rogue).empty()) << ::testing::PrintToString(seen(rogue));
  const auto from_plain = plain.call("kr", "svc", "echo", "intruder", 2s);
  EXPECT_FALSE(from_plain.ok()) << from_plain.payload;
  const auto from_rogue = rogue.call("kr", "svc", "echo", "rogue", 2s);
  EXPECT_FALSE(from_rogue.ok()) << from_rogue.payload;
}

// Member xx's permissions grant it no calls: DDS refuses its request writer, and the call says so.
TEST_F(SecuredLink, AMemberCallsOnlyTheSpacesItsPermissionsGrant) {
  const DdsDomains domains;
  serve_kr(domains[0]);
  bridge::DdsLink xx(options(domains[0], "xx", member("fed", "xx")), [] {}, no_calls);
  ASSERT_TRUE(wait_until([&] { return seen(xx).count("kr/svc") == 1; }, 30s)) << "xx, a member, never saw kr";
  const auto refused = xx.call("kr", "svc", "echo", "not granted", 5s);
  EXPECT_EQ(refused.status, call::Status::PERMISSION_DENIED) << refused.message;
  EXPECT_NE(refused.message.find("do not grant calls to space kr"), std::string::npos) << refused.message;
}

std::string joined(const std::vector<std::string>& problems) {
  std::string text;
  for (const auto& p : problems) text += p + "\n";
  return text;
}

TEST_F(SecuredLink, ABadFileIsNamedWithWhatIsWrong) {
  EXPECT_TRUE(bridge::check_dds_security(member("fed", "kr"), "kr").empty())
      << joined(bridge::check_dds_security(member("fed", "kr"), "kr"));
  struct Case {
    std::string bad;                            // what is wrong
    std::string bridge::DdsSecurity::*file;     // the file replaced
    std::string by;                             // under the test's folder
    std::string says;                           // part of the problem reported
  };
  const std::vector<Case> cases{
      {"another CA", &bridge::DdsSecurity::identity_ca, "rogue/ca.pem", "does not verify against the identity CA"},
      {"another member's permissions", &bridge::DdsSecurity::permissions, "fed/jp/permissions.p7s",
       "not the certificate's subject 'CN=kr"},
      {"an unsigned governance", &bridge::DdsSecurity::governance, "fed/governance.xml", "is not an S/MIME signed document"},
      {"another CA's governance", &bridge::DdsSecurity::governance, "rogue/governance.p7s",
       "is not signed by the documents' CA"},
      {"another member's key", &bridge::DdsSecurity::private_key, "fed/jp/identity.key", "is not the key of"},
      {"no permissions", &bridge::DdsSecurity::permissions, "fed/nobody/permissions.p7s", "cannot be read"},
  };
  // Another member's own files, for space kr: the others would take nothing it announces as kr's.
  EXPECT_NE(joined(bridge::check_dds_security(member("fed", "jp"), "kr"))
                .find("names space 'jp' (its CN), not kr: the other spaces would take nothing"),
            std::string::npos)
      << joined(bridge::check_dds_security(member("fed", "jp"), "kr"));
  for (const Case& c : cases) {
    bridge::DdsSecurity security = member("fed", "kr");
    security.*c.file = *dir_ + "/" + c.by;
    const std::string problems = joined(bridge::check_dds_security(security, "kr"));
    EXPECT_NE(problems.find(c.says), std::string::npos) << c.bad << ": " << problems;
  }

  // The link refuses to start with the problems in its message, before Fast DDS is asked.
  const DdsDomains domains;
  try {
    bridge::DdsSecurity someone_elses = member("fed", "kr");
    someone_elses.permissions = *dir_ + "/fed/jp/permissions.p7s";
    bridge::DdsLink link(options(domains[0], "kr", someone_elses), [] {}, no_calls);
    ADD_FAILURE() << "a link with another member's permissions started";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("not the certificate's subject"), std::string::npos) << e.what();
  }
}

// A revoked member is refused by the check and cannot rejoin: the others' CRL names it.
TEST_F(SecuredLink, ARevokedMemberCannotRejoin) {
  const std::string fed = *dir_ + "/fed";
  ASSERT_NO_THROW(run_pki({{"member", fed, "old", "--calls", "kr"}}));
  EXPECT_TRUE(bridge::check_dds_security(member("fed", "old"), "old").empty());
  ASSERT_NO_THROW(run_pki({{"revoke", fed, "old"}}));
  EXPECT_NE(joined(bridge::check_dds_security(member("fed", "old"), "old")).find("certificate revoked"),
            std::string::npos)
      << joined(bridge::check_dds_security(member("fed", "old"), "old"));

  // Its bridge started without the CRL (so that it gets that far) is still refused by kr's.
  const DdsDomains domains;
  serve_kr(domains[0]);
  bridge::DdsSecurity revoked = member("fed", "old");
  revoked.crl.clear();
  bridge::DdsLink old(options(domains[0], "old", revoked), [] {}, no_calls);
  bridge::DdsLink jp(options(domains[0], "jp", member("fed", "jp")), [] {}, no_calls);
  ASSERT_TRUE(wait_until([&] { return seen(jp).count("kr/svc") == 1; }, 30s));
  ASSERT_TRUE(jp.call("kr", "svc", "echo", "member", 10s).ok());
  EXPECT_TRUE(seen(old).empty()) << ::testing::PrintToString(seen(old));
}

}  // namespace
}  // namespace urs::test
