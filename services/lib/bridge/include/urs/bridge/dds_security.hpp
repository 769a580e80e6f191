#pragma once
// A secured DDS link (OMG DDS-Security with Fast DDS's builtin plugins): the files a participant
// needs to join it, checked before the participant is made. Fast DDS 2.9 reports a bad file only
// as "Cannot create participant due to initialization error"; check_dds_security() says which
// file is wrong and why. deploy/pki.sh makes the files; docs/federation.md, "A secured link".

#include <string>
#include <utility>
#include <vector>

namespace urs::bridge {

struct DdsSecurity {
  std::string identity_ca;     // PEM: the federation CA that issued every member's identity
  std::string certificate;     // PEM: this space's identity, issued by identity_ca
  std::string private_key;     // PEM: its key
  std::string permissions_ca;  // PEM: the CA that signed the documents (empty: identity_ca)
  std::string governance;      // S/MIME signed governance document
  std::string permissions;     // S/MIME signed permissions of this identity
  std::string crl;             // PEM certificate revocation list of identity_ca (optional)

  bool enabled() const { return !certificate.empty(); }
  const std::string& documents_ca() const { return permissions_ca.empty() ? identity_ca : permissions_ca; }
};

// The files of `space` in a folder laid out by deploy/pki.sh: ca.pem, governance.p7s, crl.pem (if
// present) and <space>/{identity.pem,identity.key,permissions.p7s}.
DdsSecurity security_from_folder(const std::string& folder, const std::string& space);

// What is wrong with `security` for a participant of `space` (one sentence each, naming the file),
// or nothing. Checks that every file is readable; the identity is signed by identity_ca, within its
// validity and not revoked by the CRL, and names `space` (its CN); the key is the identity's; both documents are signed by the
// documents' CA; the permissions grant the identity's subject (RFC 2253) and are valid now; and the
// governance has a rule for every topic the link uses.
std::vector<std::string> check_dds_security(const DdsSecurity& security, const std::string& space);

// The participant properties that enable the builtin plugins with these files (file:// URIs of
// absolute paths).
std::vector<std::pair<std::string, std::string>> dds_security_properties(const DdsSecurity& security);

}  // namespace urs::bridge
