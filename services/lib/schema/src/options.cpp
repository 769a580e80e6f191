// Reads the urs.options custom options. Descriptors of any pool carry their options as the
// generated google.protobuf.*Options classes, parsed with the generated extension registry; this
// file's use of the urs.options extensions links urs_options.pb.o, which registers them.
#include "urs_options.pb.h"
#include "urs/schema/schema.hpp"

namespace urs::schema {

namespace gp = google::protobuf;

std::vector<std::string> raises(const gp::MethodDescriptor& m) {
  const gp::MethodOptions& options = m.options();
  std::vector<std::string> out;
  const int count = options.ExtensionSize(urs::options::raises);
  out.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) out.push_back(options.GetExtension(urs::options::raises, i));
  return out;
}

bool is_oneway(const gp::MethodDescriptor& m) { return m.options().GetExtension(urs::options::oneway); }

std::string repository_id(const gp::ServiceDescriptor& s) {
  return s.options().GetExtension(urs::options::service_repository_id);
}

std::string repository_id(const gp::MethodDescriptor& m) {
  return m.options().GetExtension(urs::options::method_repository_id);
}

std::string repository_id(const gp::Descriptor& d) {
  return d.options().GetExtension(urs::options::message_repository_id);
}

bool is_exception(const gp::Descriptor& d) {
  return d.options().GetExtension(urs::options::message_kind) == urs::options::MESSAGE_KIND_EXCEPTION;
}

}  // namespace urs::schema
