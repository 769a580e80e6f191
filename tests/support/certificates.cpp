#include "certificates.hpp"

#include <fstream>
#include <stdexcept>
#include <vector>

#include "process.hpp"

namespace urs::test {
namespace {

void openssl(std::vector<std::string> args) {
  args.insert(args.begin(), URS_OPENSSL_BIN);
  auto result = run_command(args, std::chrono::seconds(60));
  if (result.exit_code != 0) throw std::runtime_error("openssl " + args[1] + " failed: " + result.err);
}

const std::vector<std::string> kNewKey{"-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"};

}  // namespace

void make_ca(const std::string& dir, const std::string& name) {
  std::vector<std::string> args{"req", "-x509"};
  args.insert(args.end(), kNewKey.begin(), kNewKey.end());
  args.insert(args.end(), {"-days", "2", "-subj", "/CN=" + name, "-keyout", dir + "/" + name + ".key", "-out",
                           dir + "/" + name + ".pem"});
  openssl(args);
}

void make_leaf(const std::string& dir, const std::string& name, const std::string& cn, const std::string& ca,
               const std::string& san) {
  const std::string base = dir + "/" + name;
  std::vector<std::string> request{"req"};
  request.insert(request.end(), kNewKey.begin(), kNewKey.end());
  request.insert(request.end(), {"-subj", "/CN=" + cn, "-keyout", base + ".key", "-out", base + ".csr"});
  openssl(request);
  std::vector<std::string> sign{"x509",
                                "-req",
                                "-in",
                                base + ".csr",
                                "-CA",
                                dir + "/" + ca + ".pem",
                                "-CAkey",
                                dir + "/" + ca + ".key",
                                "-CAcreateserial",
                                "-days",
                                "2",
                                "-out",
                                base + ".pem"};
  if (!san.empty()) {
    std::ofstream(base + ".ext") << "subjectAltName=" << san << "\n";
    sign.insert(sign.end(), {"-extfile", base + ".ext"});
  }
  openssl(sign);
}

void run_pki(const std::vector<std::vector<std::string>>& steps) {
  for (const auto& step : steps) {
    std::vector<std::string> argv{URS_PKI_SCRIPT};
    argv.insert(argv.end(), step.begin(), step.end());
    const CommandResult made = run_command(argv, std::chrono::seconds(60));
    if (made.exit_code != 0) {
      throw std::runtime_error("deploy/pki.sh " + (step.empty() ? std::string() : step[0]) + " failed: " + made.out +
                               made.err);
    }
  }
}

}  // namespace urs::test
