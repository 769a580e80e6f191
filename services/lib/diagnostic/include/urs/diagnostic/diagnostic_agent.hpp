#pragma once
// The diagnostic service agent (interface URS::Diagnostic, idl/urs/Diagnostic.idl): lets a new
// user try calls, deadlines, large payloads, exceptions and events before any device exists.
// urs-sam hosts it as a service agent, urs-rtc-manager as the RT-Component "Diagnostic".

#include "urs/agent/typed_agent.hpp"

namespace urs::diagnostic {

class DiagnosticAgent : public agent::TypedAgent {
 public:
  DiagnosticAgent();
};

}  // namespace urs::diagnostic
