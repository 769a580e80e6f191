// A process offering URS::Diagnostic twice over the wire: the diagnostic agent through the DSI
// (AgentServant) and an omniidl static servant of the same behaviour, the baseline the DSI is
// measured against. Writes "<dsi IOR>\n<static IOR>\n" to argv[1] once both are active, then serves
// until killed. Compiled with the stubs' modules renamed (see CMakeLists.txt).

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iostream>

#include "Diagnostic.hh"
#include "urs/corba_agent/agent_servant.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/rtc/orb.hpp"

namespace {

class StaticDiagnostic : public virtual POA_URS::Diagnostic {
 public:
  char* echo(const char* text) override { return CORBA::string_dup(text); }
  CORBA::Double add(CORBA::Double a, CORBA::Double b) override { return a + b; }
  void sleep(CORBA::ULong ms) override {
    if (urs::diagnostic::check_sleep(ms)) throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    usleep(ms * 1000);
  }
  URS::OctetSeq* blob(CORBA::ULong size) override {
    if (urs::diagnostic::check_blob(size)) throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    const std::string bytes = urs::diagnostic::patterned_bytes(size);
    auto* out = new URS::OctetSeq(size);
    out->length(size);
    std::copy(bytes.begin(), bytes.end(), out->get_buffer());
    return out;
  }
  CORBA::ULongLong checksum(const URS::OctetSeq& data) override {
    return urs::diagnostic::fnv1a64(data.get_buffer(), data.length());
  }
  void fail(const char* reason, CORBA::Long code) override { throw URS::Failure(reason, code); }
  void notify(const char*, const char*) override {}
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: diagnostic_peer <ior file>\n";
    return 2;
  }
  urs::rtc::Orb orb;
  urs::agent::DiscardingEventSink events;
  urs::corba_agent::AgentServant dsi(orb.orb(), std::make_shared<urs::diagnostic::DiagnosticAgent>(), events, {"peer"});
  StaticDiagnostic baseline;
  CORBA::Object_var dsi_ref = orb.activate(&dsi);
  CORBA::Object_var static_ref = orb.activate(&baseline);
  {
    std::ofstream out(std::string(argv[1]) + ".tmp");
    out << orb.object_to_string(dsi_ref) << "\n" << orb.object_to_string(static_ref) << "\n";
  }
  std::rename((std::string(argv[1]) + ".tmp").c_str(), argv[1]);
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigprocmask(SIG_BLOCK, &signals, nullptr);
  int received = 0;
  sigwait(&signals, &received);
  orb.deactivate(&dsi);
  orb.deactivate(&baseline);
  return 0;
}
