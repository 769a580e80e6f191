#include "urs/federation/dds_security.hpp"

#include <fnmatch.h>
#include <openssl/bio.h>
#include <openssl/evp.h>
#include <openssl/objects.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "urs/util/secret.hpp"

namespace urs::federation {

namespace {

template <class T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using KeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using CrlPtr = std::unique_ptr<X509_CRL, Deleter<X509_CRL, X509_CRL_free>>;
using BioPtr = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using StorePtr = std::unique_ptr<X509_STORE, Deleter<X509_STORE, X509_STORE_free>>;
using StoreCtxPtr = std::unique_ptr<X509_STORE_CTX, Deleter<X509_STORE_CTX, X509_STORE_CTX_free>>;
using Pkcs7Ptr = std::unique_ptr<PKCS7, Deleter<PKCS7, PKCS7_free>>;

// The topics a link of `space` uses (dds_link.cpp, state_link.cpp); another space's request and
// reply topics have the same shape as its own.
std::vector<std::string> link_topics(const std::string& space) {
  return {"urs/catalog",
          "urs/interface",
          "urs/rpc/" + space + "/request",
          "urs/rpc/" + space + "/reply",
          "urs/state/component",
          "urs/state/pose",
          "urs/state/context",
          "urs/state/event"};
}

BioPtr open_file(const std::string& path) { return BioPtr(BIO_new_file(path.c_str(), "r")); }

X509Ptr read_certificate(const std::string& path) {
  BioPtr bio = open_file(path);
  return X509Ptr(bio ? PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr) : nullptr);
}

std::string rfc2253(const X509_NAME* name) {
  BioPtr out(BIO_new(BIO_s_mem()));
  X509_NAME_print_ex(out.get(), name, 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long size = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<size_t>(size));
}

// The signed content of an S/MIME document verified against `ca`; "" with `why` set otherwise.
std::string verified_content(const std::string& path, X509_STORE* ca, std::string& why) {
  BioPtr in = open_file(path);
  if (!in) {
    why = "cannot be read";
    return {};
  }
  BIO* content = nullptr;
  Pkcs7Ptr p7(SMIME_read_PKCS7(in.get(), &content));
  BioPtr content_owner(content);
  if (!p7) {
    why = "is not an S/MIME signed document (sign it with deploy/pki.sh)";
    return {};
  }
  BioPtr out(BIO_new(BIO_s_mem()));
  if (PKCS7_verify(p7.get(), nullptr, ca, content, out.get(), PKCS7_TEXT) != 1) {
    why = "is not signed by the documents' CA";
    return {};
  }
  char* data = nullptr;
  const long size = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<size_t>(size));
}

// The text of every <tag>...</tag> in `xml`, in order (the documents are ours, signed, and flat).
std::vector<std::string> elements(const std::string& xml, const std::string& tag) {
  std::vector<std::string> out;
  const std::string open = "<" + tag + ">";
  const std::string close = "</" + tag + ">";
  for (size_t at = xml.find(open); at != std::string::npos; at = xml.find(open, at)) {
    const size_t begin = at + open.size();
    const size_t end = xml.find(close, begin);
    if (end == std::string::npos) break;
    std::string text = xml.substr(begin, end - begin);
    const size_t first = text.find_first_not_of(" \t\r\n");
    const size_t last = text.find_last_not_of(" \t\r\n");
    out.push_back(first == std::string::npos ? "" : text.substr(first, last - first + 1));
    at = end + close.size();
  }
  return out;
}

// A DDS-Security date ("2026-11-28T06:51:36", UTC) as a time_t; -1 if malformed.
std::time_t dds_date(const std::string& text) {
  std::tm tm{};
  std::istringstream in(text);
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%S");
  return in.fail() ? -1 : timegm(&tm);
}

StorePtr store_of(X509* ca) {
  StorePtr store(X509_STORE_new());
  X509_STORE_add_cert(store.get(), ca);
  return store;
}

bool matches(const std::string& expression, const std::string& name) {
  return fnmatch(expression.c_str(), name.c_str(), 0) == 0;
}

// TopicGrant from the verified text of a permissions document.
TopicGrant grant_in(const std::string& permissions, const std::string& topic, bool write) {
  TopicGrant grant;
  for (const std::string& rule : elements(permissions, "allow_rule")) {
    const std::vector<std::string> criteria = elements(rule, write ? "publish" : "subscribe");
    for (const std::string& criterion : criteria) {
      for (const std::string& expression : elements(criterion, "topic")) grant.granted |= matches(expression, topic);
    }
    if (!grant.granted) continue;
    // Fast DDS pools the partitions of every criterion of the rule.
    for (const std::string& criterion : criteria) {
      std::vector<std::string> partitions = elements(criterion, "partition");
      if (partitions.empty()) partitions.emplace_back();
      grant.partitions.insert(grant.partitions.end(), partitions.begin(), partitions.end());
    }
    break;
  }
  return grant;
}

// The first of `partitions` that `grant` does not allow (the default partition for none), or nullopt.
std::optional<std::string> refused_partition(const TopicGrant& grant, const std::vector<std::string>& partitions) {
  const std::vector<std::string> asked = partitions.empty() ? std::vector<std::string>{""} : partitions;
  for (const std::string& partition : asked) {
    bool allowed = false;
    for (const std::string& expression : grant.partitions) allowed = allowed || matches(expression, partition);
    if (!grant.granted || !allowed) return partition;
  }
  return std::nullopt;
}

std::string listed(const std::vector<std::string>& partitions) {
  std::string text;
  for (const std::string& partition : partitions) {
    text += (text.empty() ? "" : ", ") + (partition.empty() ? std::string("the default partition") : partition);
  }
  return text;
}

}  // namespace

DdsSecurity security_from_folder(const std::string& folder, const std::string& space) {
  DdsSecurity security;
  security.identity_ca = folder + "/ca.pem";
  security.certificate = folder + "/" + space + "/identity.pem";
  security.private_key = folder + "/" + space + "/identity.key";
  security.governance = folder + "/governance.p7s";
  security.permissions = folder + "/" + space + "/permissions.p7s";
  if (std::filesystem::exists(folder + "/crl.pem")) security.crl = folder + "/crl.pem";
  return security;
}

std::vector<std::string> check_dds_security(const DdsSecurity& s, const std::string& space) {
  std::vector<std::string> problems;
  const std::vector<std::pair<const char*, std::string>> files{
      {"identity CA", s.identity_ca},      {"certificate", s.certificate}, {"private key", s.private_key},
      {"documents' CA", s.documents_ca()}, {"governance", s.governance},   {"permissions", s.permissions}};
  for (const auto& [what, path] : files) {
    if (path.empty()) {
      problems.push_back(std::string("the ") + what + " is not configured");
    } else if (!std::ifstream(path).good()) {
      problems.push_back(std::string("the ") + what + " " + path + " cannot be read");
    }
  }
  if (!s.crl.empty() && !std::ifstream(s.crl).good()) problems.push_back("the CRL " + s.crl + " cannot be read");
  if (!problems.empty()) return problems;

  X509Ptr ca = read_certificate(s.identity_ca);
  X509Ptr certificate = read_certificate(s.certificate);
  X509Ptr documents_ca = read_certificate(s.documents_ca());
  if (!ca) problems.push_back("the identity CA " + s.identity_ca + " is not a PEM certificate");
  if (!certificate) problems.push_back("the certificate " + s.certificate + " is not a PEM certificate");
  if (!documents_ca) problems.push_back("the documents' CA " + s.documents_ca() + " is not a PEM certificate");
  if (!problems.empty()) return problems;

  // The identity: issued by the CA, valid now, not revoked.
  StorePtr store = store_of(ca.get());
  if (!s.crl.empty()) {
    BioPtr bio = open_file(s.crl);
    CrlPtr crl(bio ? PEM_read_bio_X509_CRL(bio.get(), nullptr, nullptr, nullptr) : nullptr);
    if (!crl) {
      problems.push_back("the CRL " + s.crl + " is not a PEM certificate revocation list");
    } else {
      X509_STORE_add_crl(store.get(), crl.get());
      X509_STORE_set_flags(store.get(), X509_V_FLAG_CRL_CHECK);
    }
  }
  StoreCtxPtr context(X509_STORE_CTX_new());
  X509_STORE_CTX_init(context.get(), store.get(), certificate.get(), nullptr);
  if (X509_verify_cert(context.get()) != 1) {
    const int error = X509_STORE_CTX_get_error(context.get());
    problems.push_back("the certificate " + s.certificate + " does not verify against the identity CA " +
                       s.identity_ca + ": " + X509_verify_cert_error_string(error));
  }
  // The space: the other bridges take what this one announces only as the space its certificate
  // names (its CN, dds_identity.hpp).
  {
    char common_name[256] = {0};
    const int length = X509_NAME_get_text_by_NID(X509_get_subject_name(certificate.get()), NID_commonName, common_name,
                                                 sizeof common_name);
    if (length < 0 || std::string(common_name, static_cast<std::size_t>(length)) != space) {
      problems.push_back("the certificate " + s.certificate + " names space '" +
                         (length < 0 ? std::string() : std::string(common_name, static_cast<std::size_t>(length))) +
                         "' (its CN), not " + space + ": the other spaces would take nothing this bridge announces");
    }
  }
  {
    BioPtr bio = open_file(s.private_key);
    KeyPtr key(bio ? PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr) : nullptr);
    if (!key) {
      problems.push_back("the private key " + s.private_key + " is not an unencrypted PEM key");
    } else if (X509_check_private_key(certificate.get(), key.get()) != 1) {
      problems.push_back("the private key " + s.private_key + " is not the key of " + s.certificate);
    }
  }

  // The documents: signed by their CA; the permissions grant this subject now.
  StorePtr documents_store = store_of(documents_ca.get());
  std::string why;
  const std::string governance = verified_content(s.governance, documents_store.get(), why);
  if (governance.empty()) {
    problems.push_back("the governance " + s.governance + " " + why);
  } else {
    const std::vector<std::string> rules = elements(governance, "topic_expression");
    for (const std::string& topic : link_topics(space)) {
      bool covered = false;
      for (const std::string& rule : rules) covered = covered || fnmatch(rule.c_str(), topic.c_str(), 0) == 0;
      if (!covered) problems.push_back("the governance " + s.governance + " has no topic rule for " + topic);
    }
  }
  const std::string permissions = verified_content(s.permissions, documents_store.get(), why);
  if (permissions.empty()) {
    problems.push_back("the permissions " + s.permissions + " " + why);
  } else {
    const std::string subject = rfc2253(X509_get_subject_name(certificate.get()));
    const std::vector<std::string> subjects = elements(permissions, "subject_name");
    bool granted = false;
    for (size_t i = 0; i < subjects.size(); ++i) {
      if (subjects[i] != subject) continue;
      granted = true;
      const std::vector<std::string> from = elements(permissions, "not_before");
      const std::vector<std::string> until = elements(permissions, "not_after");
      const std::time_t now = std::time(nullptr);
      if (i < from.size() && dds_date(from[i]) > now) {
        problems.push_back("the permissions " + s.permissions + " grant " + subject + " only from " + from[i]);
      }
      if (i < until.size() && (dds_date(until[i]) < 0 || dds_date(until[i]) < now)) {
        problems.push_back("the permissions " + s.permissions + " granted " + subject + " until " + until[i] +
                           ", which has passed");
      }
    }
    for (const std::string& topic : link_topics(space)) {
      if (!granted || !is_shared_topic(topic)) continue;
      const TopicGrant writes = grant_in(permissions, topic, true);
      if (refused_partition(writes, {space})) {
        problems.push_back("the permissions " + s.permissions + " do not let space " + space + " write " + topic +
                           " in its partition " + space + " (" +
                           (writes.granted ? "they grant " + listed(writes.partitions) : "they do not grant it") +
                           "): make them again with deploy/pki.sh member");
      }
      if (read_partitions(grant_in(permissions, topic, false)).empty()) {
        problems.push_back("the permissions " + s.permissions + " let space " + space + " read " + topic +
                           " in no space's partition: make them again with deploy/pki.sh member");
      }
    }
    if (!granted) {
      std::string named;
      for (const auto& name : subjects) named += (named.empty() ? "'" : ", '") + name + "'";
      problems.push_back("the permissions " + s.permissions + " grant " + (named.empty() ? "no subject" : named) +
                         ", not the certificate's subject '" + subject + "' (RFC 2253 order)");
    }
  }
  return problems;
}

TopicGrant topic_grant(const DdsSecurity& security, const std::string& topic, bool write) {
  X509Ptr ca = read_certificate(security.documents_ca());
  if (!ca) throw std::runtime_error("the documents' CA " + security.documents_ca() + " is not a PEM certificate");
  StorePtr store = store_of(ca.get());
  std::string why;
  const std::string permissions = verified_content(security.permissions, store.get(), why);
  if (permissions.empty()) throw std::runtime_error("the permissions " + security.permissions + " " + why);
  return grant_in(permissions, topic, write);
}

bool is_shared_topic(const std::string& topic) {
  return topic == "urs/catalog" || topic == "urs/interface" || topic.rfind("urs/state/", 0) == 0;
}

std::vector<std::string> read_partitions(const TopicGrant& grant) {
  std::vector<std::string> partitions;
  if (!grant.granted) return partitions;
  for (const std::string& expression : grant.partitions) {
    if (expression == "*") return {"*"};
    if (!expression.empty()) partitions.push_back(expression);
  }
  return partitions;
}

std::string partition_refusal(const DdsSecurity& security, const std::string& space, const std::string& topic,
                              const std::vector<std::string>& partitions, bool write) {
  std::string grants;
  std::optional<std::string> refused;
  try {
    const TopicGrant grant = topic_grant(security, topic, write);
    refused = refused_partition(grant, partitions);
    grants = grant.granted ? "they grant it in " + listed(grant.partitions) : "they do not grant " + topic;
  } catch (const std::exception& e) {
    grants = e.what();
  }
  const std::string where = refused ? listed({*refused}) : listed(partitions);
  return "dds: the permissions of member " + space + " do not let it " + (write ? "write " : "read ") + topic + " in " +
         (where == "the default partition" ? where : "partition " + where) + " (" + grants + ")";
}

std::string description_digest(const std::string& descriptor_set) { return util::sha256_hex(descriptor_set); }

std::vector<std::pair<std::string, std::string>> dds_security_properties(const DdsSecurity& s) {
  auto uri = [](const std::string& path) { return "file://" + std::filesystem::absolute(path).string(); };
  std::vector<std::pair<std::string, std::string>> properties{
      {"dds.sec.auth.plugin", "builtin.PKI-DH"},
      {"dds.sec.auth.builtin.PKI-DH.identity_ca", uri(s.identity_ca)},
      {"dds.sec.auth.builtin.PKI-DH.identity_certificate", uri(s.certificate)},
      {"dds.sec.auth.builtin.PKI-DH.private_key", uri(s.private_key)},
      {"dds.sec.access.plugin", "builtin.Access-Permissions"},
      {"dds.sec.access.builtin.Access-Permissions.permissions_ca", uri(s.documents_ca())},
      {"dds.sec.access.builtin.Access-Permissions.governance", uri(s.governance)},
      {"dds.sec.access.builtin.Access-Permissions.permissions", uri(s.permissions)},
      {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"},
  };
  if (!s.crl.empty()) properties.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_crl", uri(s.crl));
  return properties;
}

}  // namespace urs::federation
