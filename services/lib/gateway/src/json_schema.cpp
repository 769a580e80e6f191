#include "urs/gateway/json_schema.hpp"

#include <map>
#include <set>
#include <string>

#include "urs/gateway/json_writer.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;
using FD = gp::FieldDescriptor;

namespace {

// Writes schemas of message types, inlining each except those that contain themselves, which go
// to $defs once (a recursive type cannot be inlined).
class SchemaBuilder {
 public:
  explicit SchemaBuilder(const gp::Descriptor& root) { find_recursive(root); }

  std::string build(const gp::Descriptor& root) {
    JsonWriter out;
    out.begin_object();
    out.key("$schema").value("https://json-schema.org/draft/2020-12/schema");
    out.key("title").value(root.full_name());
    message_body(out, root);
    if (!recursive_.empty()) {
      out.key("$defs").begin_object();
      // Each recursive type once; writing one may not add another (all were found up front).
      for (const gp::Descriptor* type : recursive_) {
        out.key(type->full_name()).begin_object();
        out.key("title").value(type->full_name());
        message_body(out, *type);
        out.end_object();
      }
      out.end_object();
    }
    out.end_object();
    return out.take();
  }

 private:
  // Marks every message type reachable from `type` that reaches itself.
  void find_recursive(const gp::Descriptor& type) {
    if (!visiting_.insert(&type).second) {
      recursive_.insert(&type);
      return;
    }
    if (!visited_.insert(&type).second) {
      visiting_.erase(&type);
      return;
    }
    for (int i = 0; i < type.field_count(); ++i) {
      const FD* field = type.field(i);
      if (field->cpp_type() == FD::CPPTYPE_MESSAGE && !well_known(*field->message_type())) {
        find_recursive(*field->message_type());
      }
    }
    visiting_.erase(&type);
  }

  static bool well_known(const gp::Descriptor& type) { return type.file()->name().rfind("google/protobuf/", 0) == 0; }

  void message_body(JsonWriter& out, const gp::Descriptor& type) {
    out.key("type").value("object");
    out.key("properties").begin_object();
    for (int i = 0; i < type.field_count(); ++i) {
      const FD* field = type.field(i);
      out.key(field->name());
      field_schema(out, *field);
    }
    out.end_object();
    out.key("additionalProperties").value(false);
  }

  void field_schema(JsonWriter& out, const FD& field) {
    if (field.is_map()) {
      out.begin_object().key("type").value("object");
      out.key("additionalProperties");
      single_schema(out, *field.message_type()->map_value());
      out.end_object();
      return;
    }
    if (field.is_repeated()) {
      out.begin_object().key("type").value("array");
      out.key("items");
      single_schema(out, field);
      out.end_object();
      return;
    }
    single_schema(out, field);
  }

  static void integer(JsonWriter& out, int64_t min, uint64_t max) {
    out.begin_object().key("type").value("integer");
    out.key("minimum").value(min).key("maximum").value(max).end_object();
  }
  static void wide_integer(JsonWriter& out, bool is_signed) {
    // Printed as a decimal string (beyond JavaScript's exact integers); parsed from either form.
    out.begin_object().key("type").begin_array().value("integer").value("string").end_array();
    out.key("pattern").value(is_signed ? "^-?[0-9]+$" : "^[0-9]+$").end_object();
  }

  // The schema of one value of the field (an element, for a repeated field).
  void single_schema(JsonWriter& out, const FD& field) {
    switch (field.type()) {
      case FD::TYPE_DOUBLE:
      case FD::TYPE_FLOAT:
        out.begin_object().key("type").value("number").end_object();
        return;
      case FD::TYPE_INT32:
      case FD::TYPE_SINT32:
      case FD::TYPE_SFIXED32:
        integer(out, INT32_MIN, INT32_MAX);
        return;
      case FD::TYPE_UINT32:
      case FD::TYPE_FIXED32:
        integer(out, 0, UINT32_MAX);
        return;
      case FD::TYPE_INT64:
      case FD::TYPE_SINT64:
      case FD::TYPE_SFIXED64:
        wide_integer(out, true);
        return;
      case FD::TYPE_UINT64:
      case FD::TYPE_FIXED64:
        wide_integer(out, false);
        return;
      case FD::TYPE_BOOL:
        out.begin_object().key("type").value("boolean").end_object();
        return;
      case FD::TYPE_STRING:
        out.begin_object().key("type").value("string").end_object();
        return;
      case FD::TYPE_BYTES:
        out.begin_object().key("type").value("string").key("contentEncoding").value("base64").end_object();
        return;
      case FD::TYPE_ENUM: {
        const gp::EnumDescriptor& type = *field.enum_type();
        out.begin_object().key("title").value(type.full_name()).key("enum").begin_array();
        for (int i = 0; i < type.value_count(); ++i) out.value(type.value(i)->name());
        out.end_array().end_object();
        return;
      }
      case FD::TYPE_MESSAGE:
      case FD::TYPE_GROUP:
        message_schema(out, *field.message_type());
        return;
    }
    out.begin_object().end_object();
  }

  void message_schema(JsonWriter& out, const gp::Descriptor& type) {
    const std::string& name = type.full_name();
    if (well_known(type)) {
      well_known_schema(out, type);
      return;
    }
    if (recursive_.count(&type)) {
      out.begin_object().key("$ref").value("#/$defs/" + name).end_object();
      return;
    }
    out.begin_object();
    out.key("title").value(name);
    message_body(out, type);
    out.end_object();
  }

  static void well_known_schema(JsonWriter& out, const gp::Descriptor& type) {
    const std::string& name = type.full_name();
    out.begin_object().key("title").value(name);
    if (name == "google.protobuf.Value") {
      // any JSON value: no "type" constraint
    } else if (name == "google.protobuf.Struct") {
      out.key("type").value("object");
    } else if (name == "google.protobuf.ListValue") {
      out.key("type").value("array");
    } else if (name == "google.protobuf.Timestamp") {
      out.key("type").value("string").key("format").value("date-time");
    } else if (name == "google.protobuf.Duration" || name == "google.protobuf.FieldMask") {
      out.key("type").value("string");
    } else if (name == "google.protobuf.Empty") {
      out.key("type").value("object").key("additionalProperties").value(false);
    } else if (name == "google.protobuf.Any") {
      out.key("type").value("object");
    } else if (const FD* wrapped = type.FindFieldByName("value"); wrapped && name.find("Value") != std::string::npos) {
      // google.protobuf.DoubleValue etc.: the bare value, or null
      out.key("type").begin_array();
      switch (wrapped->cpp_type()) {
        case FD::CPPTYPE_DOUBLE:
        case FD::CPPTYPE_FLOAT: out.value("number"); break;
        case FD::CPPTYPE_BOOL: out.value("boolean"); break;
        case FD::CPPTYPE_INT64:
        case FD::CPPTYPE_UINT64: out.value("integer").value("string"); break;
        case FD::CPPTYPE_INT32:
        case FD::CPPTYPE_UINT32: out.value("integer"); break;
        default: out.value("string"); break;
      }
      out.value("null").end_array();
    }
    out.end_object();
  }

  std::set<const gp::Descriptor*> visiting_;
  std::set<const gp::Descriptor*> visited_;
  std::set<const gp::Descriptor*> recursive_;
};

}  // namespace

std::string json_schema(const gp::Descriptor& type) { return SchemaBuilder(type).build(type); }

}  // namespace urs::gateway
