#pragma once
// A secured DDS link (OMG DDS-Security with Fast DDS's builtin plugins): the files a participant
// needs to join it, checked before the participant is made. Fast DDS 2.9 reports a bad file only
// as "Cannot create participant due to initialization error"; check_dds_security() says which
// file is wrong and why. deploy/pki.sh makes the files; docs/federation.md, "A secured link".

#include <string>
#include <utility>
#include <vector>

namespace urs::federation {

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
// validity and not revoked by the CRL, and names `space` (its CN); the key is the identity's; both documents are signed
// by the documents' CA; the permissions grant the identity's subject (RFC 2253) and are valid now, and let it write the
// shared topics in its space's partition and read them in some space's; and the governance has a rule for every topic
// the link uses.
std::vector<std::string> check_dds_security(const DdsSecurity& security, const std::string& space);

// What a member's permissions grant it for one topic, as Fast DDS's builtin access control reads
// their signed text: the first allow rule whose publish (write) or subscribe (read) topics match
// `topic` decides, and an endpoint of that topic is allowed only if each of its partitions matches
// one of that rule's partition expressions ("" is the default partition, what a rule naming no
// partition allows). Deny rules are not read (deploy/pki.sh writes none).
struct TopicGrant {
  bool granted = false;                 // an allow rule names the topic
  std::vector<std::string> partitions;  // the partition expressions of that rule
};
// Throws std::runtime_error if the permissions cannot be read or are not signed by the documents' CA.
TopicGrant topic_grant(const DdsSecurity& security, const std::string& topic, bool write);

// The shared topics (urs/catalog, urs/interface, urs/state/*: what each space announces of
// itself, as opposed to the calls' topics). On a secured link a member writes them only in the DDS
// partition named after its space and reads them in the partitions its permissions grant
// (deploy/pki.sh member --reads), so that DDS itself refuses a member writing as another space or
// reading a space it was not granted (docs/security.md).
bool is_shared_topic(const std::string& topic);
// The partitions a member reads `topic` in: "*" if its grant has it, else the spaces it names.
std::vector<std::string> read_partitions(const TopicGrant& grant);
// The log line saying that the permissions of member `space` do not let it write (or read) `topic`
// in `partitions`, with what they grant instead.
std::string partition_refusal(const DdsSecurity& security, const std::string& space, const std::string& topic,
                              const std::vector<std::string>& partitions, bool write);

// The key of an interface description on urs/interface: SHA-256 of its bytes, 64 lower-case hex
// digits. Descriptions are content-addressed: a bridge takes one only under its own digest, so no
// member can put another schema under the digest another space's entry names.
std::string description_digest(const std::string& descriptor_set);

// The participant properties that enable the builtin plugins with these files (file:// URIs of
// absolute paths).
std::vector<std::pair<std::string, std::string>> dds_security_properties(const DdsSecurity& security);

}  // namespace urs::federation
