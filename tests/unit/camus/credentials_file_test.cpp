// The credentials file and --token-file into planet::Credentials: every error with its key.

#include "urs/camus_server/credentials_file.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "fakes.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/secret.hpp"

namespace urs::camus_server::test {
namespace {

void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string error_of(const CredentialSources& sources) {
  try {
    load_credentials(sources);
  } catch (const util::ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CredentialsFile, ReadsHashesTokenFilesAndCertificates) {
  TempDir dir;
  write(dir.file("bridge.token"), "  bridge-secret\n");
  const std::string hash = util::sha256_hex("alice-secret");
  write(dir.file("credentials.yaml"),
        "credentials:\n"
        "  - name: alice\n    role: operator\n    token_sha256: " + hash + "\n"
        "  - name: bridge-kr\n    role: sam\n    token_file: bridge.token\n"
        "  - name: bob\n    role: client\n    certificate: bob.kr.example\n");
  auto credentials = load_credentials({dir.file("credentials.yaml"), "", "space", planet::ROLE_UNSPECIFIED});
  ASSERT_NE(credentials, nullptr);
  EXPECT_EQ(credentials->all().size(), 3u);
  EXPECT_EQ(credentials->admit("alice-secret", "").name, "alice");
  EXPECT_EQ(credentials->admit("bridge-secret", "").role, planet::SAM);  // the file's token, trimmed
  EXPECT_EQ(credentials->admit("", "bob.kr.example").name, "bob");
}

TEST(CredentialsFile, NoSourceIsAnOpenServer) {
  EXPECT_EQ(load_credentials({}), nullptr);
}

TEST(CredentialsFile, TheSingleTokenIsOneCredentialWithAnExplicitRole) {
  TempDir dir;
  write(dir.file("token"), "shared\n");
  auto credentials = load_credentials({"", dir.file("token"), "kr-space", planet::SAM});
  ASSERT_NE(credentials, nullptr);
  auto admitted = credentials->admit("shared", "");
  EXPECT_EQ(admitted.name, "kr-space");
  EXPECT_EQ(admitted.role, planet::SAM);
  EXPECT_EQ(error_of({"", dir.file("token"), "space", planet::ROLE_UNSPECIFIED}),
            "--token-file needs --token-role (client, sam or operator): the role of the one credential it holds");
  EXPECT_EQ(error_of({"", dir.file("missing"), "space", planet::CLIENT}),
            "--token-file: token file '" + dir.file("missing") + "' cannot be read");
}

TEST(CredentialsFile, EveryMistakeIsReportedWithItsKey) {
  TempDir dir;
  write(dir.file("credentials.yaml"),
        "credentials:\n"
        "  - name: alice\n    role: admin\n    token_sha256: abc\n"
        "  - role: client\n    token_file: nowhere.token\n"
        "  - name: carol\n    role: sam\n"
        "  - name: dave\n    role: sam\n    token_sha256: " + util::sha256_hex("d") + "\n    token_file: d.token\n"
        "  - name: erin\n    role: client\n    token_sha256: " + util::sha256_hex("e") + "\n    colour: blue\n");
  const std::string m = error_of({dir.file("credentials.yaml"), "", "space", planet::ROLE_UNSPECIFIED});
  EXPECT_NE(m.find("--credentials '" + dir.file("credentials.yaml") + "'"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[0].role: 'admin' is not client, sam or operator"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[0].token_sha256: is not 64 hex digits"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[1].name: is missing"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[1].token_file: token file '" + dir.file("nowhere.token") + "' cannot be read"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("credentials[2]: needs token_sha256, token_file or certificate"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[3]: give token_sha256 or token_file, not both"), std::string::npos) << m;
  EXPECT_NE(m.find("credentials[4].colour: unknown key"), std::string::npos) << m;
}

TEST(CredentialsFile, ConflictsBetweenEntriesAreNamed) {
  TempDir dir;
  write(dir.file("token"), "same\n");
  write(dir.file("credentials.yaml"),
        "credentials:\n"
        "  - name: alice\n    role: client\n    token_sha256: " + util::sha256_hex("same") + "\n"
        "  - name: alice\n    role: sam\n    certificate: a.example\n");
  const std::string m = error_of({dir.file("credentials.yaml"), dir.file("token"), "space", planet::OPERATOR});
  EXPECT_NE(m.find("with --token-file"), std::string::npos) << m;
  EXPECT_NE(m.find("credential 'alice': the name is given twice"), std::string::npos) << m;
  EXPECT_NE(m.find("credential 'space': has the same token as credential 'alice'"), std::string::npos) << m;
}

TEST(CredentialsFile, NotACredentialsFile) {
  TempDir dir;
  write(dir.file("list.yaml"), "- a\n- b\n");
  EXPECT_NE(error_of({dir.file("list.yaml"), "", "space", planet::ROLE_UNSPECIFIED})
                .find("the file must be a map with the key 'credentials'"),
            std::string::npos);
  write(dir.file("empty.yaml"), "credentials: 3\n");
  EXPECT_NE(error_of({dir.file("empty.yaml"), "", "space", planet::ROLE_UNSPECIFIED})
                .find("credentials: must be a list"),
            std::string::npos);
  EXPECT_NE(error_of({dir.file("absent.yaml"), "", "space", planet::ROLE_UNSPECIFIED}).find("cannot read"),
            std::string::npos);
}

TEST(CredentialsFile, RolesByWord) {
  EXPECT_EQ(parse_role("client"), planet::CLIENT);
  EXPECT_EQ(parse_role("sam"), planet::SAM);
  EXPECT_EQ(parse_role("operator"), planet::OPERATOR);
  EXPECT_EQ(parse_role("Operator"), planet::ROLE_UNSPECIFIED);
}

}  // namespace
}  // namespace urs::camus_server::test
