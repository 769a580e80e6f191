#pragma once
// Test certificates made with the openssl command: a CA, and leaf certificates it signs (EC
// P-256, valid two days), for TLS tests. Each throws std::runtime_error with openssl's message.

#include <string>
#include <vector>

namespace urs::test {

// DIR/NAME.pem and DIR/NAME.key: a self-signed CA with subject CN=NAME.
void make_ca(const std::string& dir, const std::string& name);
// DIR/NAME.pem and DIR/NAME.key with subject CN=CN, signed by DIR/CA.pem; `san` (e.g.
// "IP:127.0.0.1,DNS:localhost") adds subject alternative names, as a server certificate needs.
void make_leaf(const std::string& dir, const std::string& name, const std::string& cn, const std::string& ca,
               const std::string& san = "");

// Runs the project's deploy/pki.sh once per step (the arguments after the script, e.g. {"init",
// DIR}), in order: a federation PKI for DDS-Security. Throws std::runtime_error with the script's
// output when a step fails.
void run_pki(const std::vector<std::vector<std::string>>& steps);

}  // namespace urs::test
