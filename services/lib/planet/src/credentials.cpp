#include "urs/planet/credentials.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <stdexcept>

#include "urs/util/secret.hpp"

namespace urs::planet {

std::string Credentials::name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > 64) return "it is longer than 64 characters";
  for (char c : name) {
    const bool ok =
        std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '_' || c == '-' || c == '@' || c == ':';
    if (!ok) return std::string("character '") + c + "' is not allowed (use letters, digits and . _ - @ :)";
  }
  if (name == "camus-server" || name == kAnonymousIdentity) return "it is reserved for the server";
  return {};
}

Credentials::Credentials(std::vector<Credential> credentials) : credentials_(std::move(credentials)) {
  std::vector<std::string> errors;
  std::map<std::string, std::string> names;
  std::map<std::string, std::string> tokens;
  std::map<std::string, std::string> certificates;
  for (size_t i = 0; i < credentials_.size(); ++i) {
    Credential& c = credentials_[i];
    const std::string which = c.name.empty() ? "credential " + std::to_string(i + 1) : "credential '" + c.name + "'";
    if (auto why = name_problem(c.name); !why.empty()) errors.push_back(which + ": name is not valid: " + why);
    if (!names.emplace(c.name, which).second) errors.push_back(which + ": the name is given twice");
    if (c.role != CLIENT && c.role != SAM && c.role != OPERATOR) {
      errors.push_back(which + ": role must be client, sam or operator");
    }
    if (c.token_sha256.empty() && c.certificate.empty()) {
      errors.push_back(which + ": has neither a token nor a certificate, so nobody can present it");
    }
    if (!c.token_sha256.empty()) {
      if (!util::is_sha256_hex(c.token_sha256)) {
        errors.push_back(which + ": the token hash is not 64 hex digits (a SHA-256)");
      }
      std::transform(c.token_sha256.begin(), c.token_sha256.end(), c.token_sha256.begin(),
                     [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
      auto [at, added] = tokens.emplace(c.token_sha256, which);
      if (!added) errors.push_back(which + ": has the same token as " + at->second);
    }
    if (!c.certificate.empty()) {
      auto [at, added] = certificates.emplace(c.certificate, which);
      if (!added) errors.push_back(which + ": has the same certificate name as " + at->second);
    }
  }
  if (errors.empty()) return;
  std::string message = "invalid credentials:";
  for (const auto& error : errors) message += "\n  " + error;
  throw std::invalid_argument(message);
}

Admission Credentials::admit(const std::string& token, const std::string& certificate) const {
  Admission admission;
  const Credential* found = nullptr;
  if (!token.empty()) {
    // Every stored hash is compared, whichever matches, so the time says nothing about which.
    const std::string presented = util::sha256_hex(token);
    for (const auto& c : credentials_) {
      const bool match = !c.token_sha256.empty() && util::constant_time_equal(presented, c.token_sha256);
      if (match) found = &c;
    }
    if (found == nullptr) {
      admission.status = UNAUTHENTICATED;
      admission.reason = "wrong token";
      return admission;
    }
  } else if (!certificate.empty()) {
    for (const auto& c : credentials_) {
      if (c.certificate == certificate) found = &c;
    }
    if (found == nullptr) {
      admission.status = UNAUTHENTICATED;
      admission.reason = "client certificate '" + certificate + "' names no credential of this server";
      return admission;
    }
  } else {
    admission.status = UNAUTHENTICATED;
    admission.reason = "token required: pass --token-file";
    return admission;
  }
  admission.name = found->name;
  admission.role = found->role;
  admission.fingerprint = fingerprint(found->name);
  return admission;
}

std::string Credentials::fingerprint(const std::string& name) const {
  for (const auto& c : credentials_) {
    if (c.name == name) {
      return util::sha256_hex(std::string(role_word(c.role)) + "\n" + c.token_sha256 + "\n" + c.certificate);
    }
  }
  return {};
}

}  // namespace urs::planet
