#pragma once
// The diagnostic service agent (interface URS::Diagnostic, idl/urs/Diagnostic.idl): lets a new
// user try calls, deadlines, large payloads, exceptions and events before any device exists.

#include "urs/agent/typed_agent.hpp"

namespace urs::sam {

class DiagnosticAgent : public agent::TypedAgent {
 public:
  DiagnosticAgent();
};

}  // namespace urs::sam
