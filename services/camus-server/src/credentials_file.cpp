#include "urs/camus_server/credentials_file.hpp"

#include <filesystem>
#include <stdexcept>
#include <vector>

#include "urs/util/cli.hpp"
#include "urs/util/files.hpp"
#include "urs/util/secret.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::camus_server {

namespace {

// The token in the token file `path`, read as a server re-reads files (util::read_regular_file:
// a regular file of at most 1 MiB, never blocking).
std::string read_token(const std::string& path) {
  return util::token_from_text(util::read_regular_file(path, util::kMaxReloadFileBytes), path);
}

// The token in `path` (relative to `base`), hashed; appends an error and returns "" if unreadable.
std::string hash_token_file(const std::string& path, const std::string& base, const std::string& where,
                            std::vector<std::string>& errors) {
  std::filesystem::path file(path);
  if (file.is_relative() && !base.empty()) file = std::filesystem::path(base) / file;
  try {
    return util::sha256_hex(read_token(file.string()));
  } catch (const util::ConfigError& e) {
    errors.push_back(where + ": " + e.what());
    return {};
  }
}

void read_file(const std::string& path, std::vector<planet::Credential>& out, std::vector<std::string>& errors) {
  YAML::Node root;
  try {
    root = YAML::Load(util::read_regular_file(path, util::kMaxReloadFileBytes));
  } catch (const util::ConfigError& e) {
    throw util::ConfigError(std::string("--credentials: ") + e.what());
  } catch (const YAML::Exception& e) {
    throw util::ConfigError("--credentials: '" + path + "' is not valid YAML: " + e.what());
  }
  if (!root.IsMap()) {
    errors.push_back("the file must be a map with the key 'credentials'");
    return;
  }
  util::check_keys(root, "", {"credentials"}, errors);
  const YAML::Node list = root["credentials"];
  if (!list || !list.IsSequence()) {
    errors.push_back("credentials: must be a list of {name, role, token_sha256 | token_file, certificate}");
    return;
  }
  const std::string base = std::filesystem::path(path).parent_path().string();
  util::for_each_map(
      list, "credentials", "name, role and token_sha256, token_file or certificate",
      {"name", "role", "token_sha256", "token_file", "certificate"}, errors,
      [&](const YAML::Node& entry, const std::string& where) {
        planet::Credential credential;
        if (!entry["name"]) {
          errors.push_back(where + ".name: is missing");
        } else {
          util::read_scalar(entry["name"], where + ".name", credential.name, errors);
        }
        std::string role;
        if (!entry["role"]) {
          errors.push_back(where + ".role: is missing (client, sam or operator)");
        } else if (util::read_scalar(entry["role"], where + ".role", role, errors)) {
          credential.role = parse_role(role);
          if (credential.role == planet::ROLE_UNSPECIFIED) {
            errors.push_back(where + ".role: '" + role + "' is not client, sam or operator");
          }
        }
        if (entry["token_sha256"] && entry["token_file"]) {
          errors.push_back(where + ": give token_sha256 or token_file, not both");
        } else if (entry["token_sha256"]) {
          if (util::read_scalar(entry["token_sha256"], where + ".token_sha256", credential.token_sha256, errors) &&
              !util::is_sha256_hex(credential.token_sha256)) {
            errors.push_back(where + ".token_sha256: is not 64 hex digits (printf %s \"$TOKEN\" | sha256sum)");
          }
        } else if (entry["token_file"]) {
          std::string file;
          if (util::read_scalar(entry["token_file"], where + ".token_file", file, errors)) {
            credential.token_sha256 = hash_token_file(file, base, where + ".token_file", errors);
          }
        }
        if (entry["certificate"]) {
          util::read_scalar(entry["certificate"], where + ".certificate", credential.certificate, errors);
        }
        if (!entry["token_sha256"] && !entry["token_file"] && !entry["certificate"]) {
          errors.push_back(where + ": needs token_sha256, token_file or certificate");
        }
        out.push_back(std::move(credential));
      });
}

}  // namespace

planet::Role parse_role(const std::string& word) {
  if (word == "client") return planet::CLIENT;
  if (word == "sam") return planet::SAM;
  if (word == "operator") return planet::OPERATOR;
  return planet::ROLE_UNSPECIFIED;
}

std::shared_ptr<const planet::Credentials> load_credentials(const CredentialSources& sources) {
  if (!sources.any()) return nullptr;
  std::vector<planet::Credential> credentials;
  if (!sources.credentials_file.empty()) {
    std::vector<std::string> errors;
    read_file(sources.credentials_file, credentials, errors);
    util::throw_if_errors(errors, "--credentials '" + sources.credentials_file + "'");
  }
  if (!sources.token_file.empty()) {
    if (sources.token_role == planet::ROLE_UNSPECIFIED) {
      throw util::ConfigError(
          "--token-file needs --token-role (client, sam or operator): the role of the one "
          "credential it holds");
    }
    planet::Credential single;
    single.name = sources.token_name;
    single.role = sources.token_role;
    try {
      single.token_sha256 = util::sha256_hex(read_token(sources.token_file));
    } catch (const util::ConfigError& e) {
      throw util::ConfigError(std::string("--token-file: ") + e.what());
    }
    credentials.push_back(std::move(single));
  }
  try {
    return std::make_shared<const planet::Credentials>(std::move(credentials));
  } catch (const std::invalid_argument& e) {
    std::string from =
        sources.credentials_file.empty() ? "--token-file" : "--credentials '" + sources.credentials_file + "'";
    if (!sources.credentials_file.empty() && !sources.token_file.empty()) from += " with --token-file";
    throw util::ConfigError(from + ": " + e.what());
  }
}

}  // namespace urs::camus_server
