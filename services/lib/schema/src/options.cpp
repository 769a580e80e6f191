// Reads the urs.options custom options. Descriptors of any pool carry their options as the
// generated google.protobuf.*Options classes, parsed with the generated extension registry; this
// file's use of the urs.options extensions links urs_options.pb.o, which registers them.
#include <algorithm>

#include "urs/schema/schema.hpp"
#include "urs_options.pb.h"

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

namespace {

// "URC.InvalidTarget" -> "URC::InvalidTarget".
std::string scoped(const std::string& protobuf_name) {
  std::string out;
  for (char c : protobuf_name) out += c == '.' ? std::string("::") : std::string(1, c);
  return out;
}

std::string idl_type_of(const gp::FieldDescriptor& field) {
  std::string type = field.options().GetExtension(urs::options::idl_type);
  if (!type.empty()) {
    // "::URC::Pose2D", "sequence<::URC::Marker,8>": scoped names as a person writes them.
    for (const char* absolute : {"<::", ",::"}) {
      for (auto at = type.find(absolute); at != std::string::npos; at = type.find(absolute, at)) type.erase(at + 1, 2);
    }
    if (type.rfind("::", 0) == 0) type.erase(0, 2);
    for (int i = 0; i < field.options().ExtensionSize(urs::options::array_dims); ++i) {
      type += "[" + std::to_string(field.options().GetExtension(urs::options::array_dims, i)) + "]";
    }
    return type;
  }
  if (field.message_type() != nullptr) return scoped(field.message_type()->full_name());
  if (field.enum_type() != nullptr) return scoped(field.enum_type()->full_name());
  return field.is_repeated() ? std::string("repeated ") + field.type_name() : field.type_name();
}

}  // namespace

std::string idl_signature(const gp::MethodDescriptor& m) {
  const std::string attribute = m.options().GetExtension(urs::options::attribute);
  if (!attribute.empty()) {
    if (m.name().rfind("_set_", 0) == 0) return "";
    const gp::FieldDescriptor* result = m.output_type()->FindFieldByName("result");
    const bool settable = m.service()->FindMethodByName("_set_" + attribute) != nullptr;
    return std::string(settable ? "" : "readonly ") + "attribute " + (result ? idl_type_of(*result) : "?") + " " +
           attribute;
  }
  struct Parameter {
    unsigned position;
    std::string text;
  };
  std::vector<Parameter> parameters;
  std::string result_type = "void";
  auto collect = [&](const gp::Descriptor& message, bool reply) {
    for (int i = 0; i < message.field_count(); ++i) {
      const gp::FieldDescriptor& field = *message.field(i);
      const auto& options = field.options();
      urs::options::ParamMode mode = options.GetExtension(urs::options::param_mode);
      if (mode == urs::options::PARAM_MODE_UNSPECIFIED) {
        mode = !reply                     ? urs::options::PARAM_MODE_IN
               : field.name() == "result" ? urs::options::PARAM_MODE_RETURN
                                          : urs::options::PARAM_MODE_OUT;
      }
      if (mode == urs::options::PARAM_MODE_RETURN) {
        result_type = idl_type_of(field);
        continue;
      }
      if (reply && mode == urs::options::PARAM_MODE_INOUT) continue;  // listed from the Request
      const char* direction = mode == urs::options::PARAM_MODE_OUT     ? "out"
                              : mode == urs::options::PARAM_MODE_INOUT ? "inout"
                                                                       : "in";
      const unsigned position = options.HasExtension(urs::options::param_position)
                                    ? options.GetExtension(urs::options::param_position)
                                    : static_cast<unsigned>(parameters.size() + 1) * 1000;
      parameters.push_back({position, std::string(direction) + " " + idl_type_of(field) + " " + field.name()});
    }
  };
  collect(*m.input_type(), false);
  collect(*m.output_type(), true);
  std::stable_sort(parameters.begin(), parameters.end(),
                   [](const Parameter& a, const Parameter& b) { return a.position < b.position; });
  std::string out = (is_oneway(m) ? "oneway " : "") + result_type + " " + m.name() + "(";
  for (std::size_t i = 0; i < parameters.size(); ++i) out += (i ? ", " : "") + parameters[i].text;
  out += ")";
  const auto raised = raises(m);
  if (!raised.empty()) {
    out += " raises (";
    for (std::size_t i = 0; i < raised.size(); ++i) out += (i ? ", " : "") + scoped(raised[i]);
    out += ")";
  }
  return out;
}

}  // namespace urs::schema
