#include "corba_stub.hpp"

#include <stdexcept>

#include "Diagnostic.hh"

namespace urs::bench {

struct DiagnosticStub::Impl {
  URS::Diagnostic_var target;
};

DiagnosticStub::DiagnosticStub(CORBA::Object_ptr object) : impl_(std::make_unique<Impl>()) {
  impl_->target = URS::Diagnostic::_narrow(object);
  if (CORBA::is_nil(impl_->target)) throw std::runtime_error("not a URS::Diagnostic");
}

DiagnosticStub::~DiagnosticStub() = default;

std::string DiagnosticStub::echo(const std::string& text) {
  CORBA::String_var reply = impl_->target->echo(text.c_str());
  return reply.in();
}

std::size_t DiagnosticStub::blob(uint32_t size) {
  URS::OctetSeq_var bytes = impl_->target->blob(size);
  return bytes->length();
}

}  // namespace urs::bench
