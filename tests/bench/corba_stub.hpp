#pragma once
// URS::Diagnostic called through omniidl's static stubs: the direct omniORB path the bridged rows
// are compared with. Kept apart from the Protobuf classes of the same IDL (one file cannot hold both).

#include <omniORB4/CORBA.h>

#include <cstdint>
#include <memory>
#include <string>

namespace urs::bench {

class DiagnosticStub {
 public:
  explicit DiagnosticStub(CORBA::Object_ptr object);  // throws std::runtime_error if not a URS::Diagnostic
  ~DiagnosticStub();
  std::string echo(const std::string& text);
  std::size_t blob(uint32_t size);  // the reply's length

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::bench
