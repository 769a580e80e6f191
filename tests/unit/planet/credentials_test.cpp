// planet::Credentials: validation of the set, admission by token or certificate, fingerprints.

#include "urs/planet/credentials.hpp"

#include <gtest/gtest.h>

#include "urs/util/secret.hpp"

namespace urs::planet {
namespace {

Credential with_token(const std::string& name, Role role, const std::string& token) {
  return Credential{name, role, util::sha256_hex(token), ""};
}

TEST(PlanetCredentials, AdmitsByTokenWhicheverCredentialItIs) {
  Credentials credentials({with_token("alice", OPERATOR, "a-token"), with_token("robot1", SAM, "r-token"),
                           Credential{"bob", CLIENT, "", "bob.kr.example"}});
  auto alice = credentials.admit("a-token", "");
  ASSERT_TRUE(alice.ok()) << alice.reason;
  EXPECT_EQ(alice.name, "alice");
  EXPECT_EQ(alice.role, OPERATOR);
  EXPECT_EQ(alice.fingerprint, credentials.fingerprint("alice"));
  EXPECT_EQ(credentials.admit("r-token", "").name, "robot1");
  // A token decides even with a certificate; without a token the certificate does.
  EXPECT_EQ(credentials.admit("r-token", "bob.kr.example").name, "robot1");
  EXPECT_EQ(credentials.admit("", "bob.kr.example").name, "bob");
}

TEST(PlanetCredentials, RefusalsSayWhyWithoutTheSecret) {
  Credentials credentials({with_token("alice", OPERATOR, "a-token")});
  auto none = credentials.admit("", "");
  EXPECT_EQ(none.status, UNAUTHENTICATED);
  EXPECT_EQ(none.reason, "token required: pass --token-file");
  auto wrong = credentials.admit("a-tokem", "");
  EXPECT_EQ(wrong.status, UNAUTHENTICATED);
  EXPECT_EQ(wrong.reason, "wrong token");
  auto unknown = credentials.admit("", "mallory.example");
  EXPECT_EQ(unknown.status, UNAUTHENTICATED);
  EXPECT_EQ(unknown.reason, "client certificate 'mallory.example' names no credential of this server");
}

TEST(PlanetCredentials, HashesAreComparedWhateverTheirCase) {
  Credential upper = with_token("alice", CLIENT, "a-token");
  for (auto& c : upper.token_sha256) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  Credentials credentials({upper});
  EXPECT_TRUE(credentials.admit("a-token", "").ok());
}

TEST(PlanetCredentials, EveryProblemOfTheSetIsReportedAtOnce) {
  try {
    Credentials credentials({with_token("alice", OPERATOR, "same"), with_token("alice", CLIENT, "other"),
                             with_token("camus-server", SAM, "x"), with_token("bad name", SAM, "y"),
                             with_token("twin", SAM, "same"), Credential{"nothing", SAM, "", ""},
                             Credential{"short", SAM, "abc", ""}, Credential{"cert1", CLIENT, "", "c"},
                             Credential{"cert2", CLIENT, "", "c"}, with_token("norole", ROLE_UNSPECIFIED, "z")});
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("credential 'alice': the name is given twice"), std::string::npos) << m;
    EXPECT_NE(m.find("credential 'camus-server': name is not valid: it is reserved for the server"), std::string::npos);
    EXPECT_NE(m.find("credential 'bad name': name is not valid: character ' ' is not allowed"), std::string::npos);
    EXPECT_NE(m.find("credential 'twin': has the same token as credential 'alice'"), std::string::npos);
    EXPECT_NE(m.find("credential 'nothing': has neither a token nor a certificate"), std::string::npos);
    EXPECT_NE(m.find("credential 'short': the token hash is not 64 hex digits"), std::string::npos);
    EXPECT_NE(m.find("credential 'cert2': has the same certificate name as credential 'cert1'"), std::string::npos);
    EXPECT_NE(m.find("credential 'norole': role must be client, sam or operator"), std::string::npos);
  }
}

TEST(PlanetCredentials, FingerprintChangesWithRoleTokenOrCertificate) {
  Credentials one({with_token("alice", CLIENT, "a")});
  Credentials role({with_token("alice", OPERATOR, "a")});
  Credentials token({with_token("alice", CLIENT, "b")});
  Credentials same({with_token("alice", CLIENT, "a"), with_token("bob", SAM, "b")});
  EXPECT_NE(one.fingerprint("alice"), role.fingerprint("alice"));
  EXPECT_NE(one.fingerprint("alice"), token.fingerprint("alice"));
  EXPECT_EQ(one.fingerprint("alice"), same.fingerprint("alice"));
  EXPECT_EQ(one.fingerprint("bob"), "");
  EXPECT_EQ(one.fingerprint("alice").find(util::sha256_hex("a")), std::string::npos) << "no token hash in it";
}

}  // namespace
}  // namespace urs::planet
