// The credentials file and --token-file into planet::Credentials: every error with its key.

#include "urs/camus_server/credentials_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "fakes.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/secret.hpp"

namespace urs::camus_server::test {
namespace {

using ::testing::HasSubstr;

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
        "  - name: alice\n    role: operator\n    token_sha256: " +
            hash +
            "\n"
            "  - name: bridge-kr\n    role: sam\n    token_file: bridge.token\n"
            "  - name: bob\n    role: client\n    certificate: bob.kr.example\n");
  auto credentials = load_credentials({dir.file("credentials.yaml"), "", "space", planet::ROLE_UNSPECIFIED});
  ASSERT_NE(credentials, nullptr);
  EXPECT_EQ(credentials->all().size(), 3u);
  EXPECT_EQ(credentials->admit("alice-secret", "").name, "alice");
  EXPECT_EQ(credentials->admit("bridge-secret", "").role, planet::SAM);  // the file's token, trimmed
  EXPECT_EQ(credentials->admit("", "bob.kr.example").name, "bob");
}

TEST(CredentialsFile, NoSourceIsAnOpenServer) { EXPECT_EQ(load_credentials({}), nullptr); }

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
            "--token-file: '" + dir.file("missing") + "' cannot be opened: No such file or directory");
}

TEST(CredentialsFile, EveryMistakeIsReportedWithItsKey) {
  TempDir dir;
  write(dir.file("credentials.yaml"),
        "credentials:\n"
        "  - name: alice\n    role: admin\n    token_sha256: abc\n"
        "  - role: client\n    token_file: nowhere.token\n"
        "  - name: carol\n    role: sam\n"
        "  - name: dave\n    role: sam\n    token_sha256: " +
            util::sha256_hex("d") +
            "\n    token_file: d.token\n"
            "  - name: erin\n    role: client\n    token_sha256: " +
            util::sha256_hex("e") + "\n    colour: blue\n");
  const std::string m = error_of({dir.file("credentials.yaml"), "", "space", planet::ROLE_UNSPECIFIED});
  EXPECT_THAT(m, HasSubstr("--credentials '" + dir.file("credentials.yaml") + "'"));
  EXPECT_THAT(m, HasSubstr("credentials[0].role: 'admin' is not client, sam or operator"));
  EXPECT_THAT(m, HasSubstr("credentials[0].token_sha256: is not 64 hex digits"));
  EXPECT_THAT(m, HasSubstr("credentials[1].name: is missing"));
  EXPECT_THAT(m, HasSubstr("credentials[1].token_file: '" + dir.file("nowhere.token") +
                           "' cannot be opened: No such file or directory"));
  EXPECT_THAT(m, HasSubstr("credentials[2]: needs token_sha256, token_file or certificate"));
  EXPECT_THAT(m, HasSubstr("credentials[3]: give token_sha256 or token_file, not both"));
  EXPECT_THAT(m, HasSubstr("credentials[4].colour: unknown key"));
}

TEST(CredentialsFile, ConflictsBetweenEntriesAreNamed) {
  TempDir dir;
  write(dir.file("token"), "same\n");
  write(dir.file("credentials.yaml"),
        "credentials:\n"
        "  - name: alice\n    role: client\n    token_sha256: " +
            util::sha256_hex("same") +
            "\n"
            "  - name: alice\n    role: sam\n    certificate: a.example\n");
  const std::string m = error_of({dir.file("credentials.yaml"), dir.file("token"), "space", planet::OPERATOR});
  EXPECT_THAT(m, HasSubstr("with --token-file"));
  EXPECT_THAT(m, HasSubstr("credential 'alice': the name is given twice"));
  EXPECT_THAT(m, HasSubstr("credential 'space': has the same token as credential 'alice'"));
}

TEST(CredentialsFile, NotACredentialsFile) {
  TempDir dir;
  write(dir.file("list.yaml"), "- a\n- b\n");
  EXPECT_THAT(error_of({dir.file("list.yaml"), "", "space", planet::ROLE_UNSPECIFIED}),
              HasSubstr("the file must be a map with the key 'credentials'"));
  write(dir.file("empty.yaml"), "credentials: 3\n");
  EXPECT_THAT(error_of({dir.file("empty.yaml"), "", "space", planet::ROLE_UNSPECIFIED}),
              HasSubstr("credentials: must be a list"));
  EXPECT_THAT(error_of({dir.file("absent.yaml"), "", "space", planet::ROLE_UNSPECIFIED}),
              HasSubstr("absent.yaml' cannot be opened"));
}

TEST(CredentialsFile, RolesByWord) {
  EXPECT_EQ(parse_role("client"), planet::CLIENT);
  EXPECT_EQ(parse_role("sam"), planet::SAM);
  EXPECT_EQ(parse_role("operator"), planet::OPERATOR);
  EXPECT_EQ(parse_role("Operator"), planet::ROLE_UNSPECIFIED);
}

}  // namespace
}  // namespace urs::camus_server::test
