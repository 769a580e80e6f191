#include "urs/gateway/json_schema.hpp"

#include <cstdint>
#include <set>
#include <string>

#include "urs/gateway/foxglove_json.hpp"
#include "urs/gateway/json_writer.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;
using FD = gp::FieldDescriptor;

namespace {

// Writes the schema of a message type with every message type inlined; a type met again inside
// itself is cut there (an object whose properties are not listed), since neither Foxglove nor
// Lichtblick follows "$ref".
class SchemaBuilder {
 public:
  std::string build(const gp::Descriptor& root) {
    JsonWriter out;
    out.begin_object();
    out.key("$schema").value("https://json-schema.org/draft/2020-12/schema");
    out.key("title").value(root.full_name());
    path_.insert(&root);
    message_body(out, root);
    path_.erase(&root);
    out.end_object();
    return out.take();
  }

 private:
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
      // The keys are data, not fields: no properties are listed (the readers require the key).
      out.begin_object().key("type").value("object");
      out.key("properties").begin_object().end_object();
      out.key("additionalProperties");
      single_schema(out, *field.message_type()->map_value(), false);
      out.end_object();
      return;
    }
    if (field.is_repeated()) {
      out.begin_object().key("type").value("array");
      out.key("items");
      single_schema(out, field, true);
      out.end_object();
      return;
    }
    single_schema(out, field, false);
  }

  static void integer(JsonWriter& out, int64_t min, uint64_t max) {
    out.begin_object().key("type").value("integer");
    out.key("minimum").value(min).key("maximum").value(max).end_object();
  }
  static void decimal_string(JsonWriter& out, bool is_signed) {
    // Printed as a decimal string (beyond JavaScript's exact integers); a number is accepted too.
    out.begin_object().key("type").value("string");
    out.key("pattern").value(is_signed ? "^-?[0-9]+$" : "^[0-9]+$").end_object();
  }
  static void json_text(JsonWriter& out, const std::string& title) {
    out.begin_object().key("title").value(title).key("type").value("string");
    out.key("contentMediaType").value("application/json").end_object();
  }

  // The schema of one value of the field (an element, for a repeated field: `in_array`).
  void single_schema(JsonWriter& out, const FD& field, bool in_array) {
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
        decimal_string(out, true);
        return;
      case FD::TYPE_UINT64:
      case FD::TYPE_FIXED64:
        decimal_string(out, false);
        return;
      case FD::TYPE_BOOL:
        out.begin_object().key("type").value("boolean").end_object();
        return;
      case FD::TYPE_STRING:
        out.begin_object().key("type").value("string").end_object();
        return;
      case FD::TYPE_BYTES:
        out.begin_object().key("type").value("string");
        if (in_array) {
          // The readers refuse contentEncoding on array items: the same base64, said by a pattern.
          out.key("pattern").value("^[A-Za-z0-9+/]*={0,2}$");
        } else {
          out.key("contentEncoding").value("base64");
        }
        out.end_object();
        return;
      case FD::TYPE_ENUM: {
        const gp::EnumDescriptor& type = *field.enum_type();
        out.begin_object().key("title").value(type.full_name()).key("type").value("string");
        out.key("enum").begin_array();
        for (int i = 0; i < type.value_count(); ++i) out.value(type.value(i)->name());
        out.end_array().end_object();
        return;
      }
      case FD::TYPE_MESSAGE:
      case FD::TYPE_GROUP:
        message_schema(out, *field.message_type());
        return;
    }
    out.begin_object().key("type").value("string").end_object();
  }

  void message_schema(JsonWriter& out, const gp::Descriptor& type) {
    const std::string& name = type.full_name();
    if (well_known(type)) {
      well_known_schema(out, type);
      return;
    }
    out.begin_object();
    out.key("title").value(name);
    if (path_.count(&type)) {
      // Inside itself: any object (its properties are those of the enclosing "title" above).
      out.key("type").value("object").key("properties").begin_object().end_object();
    } else {
      path_.insert(&type);
      message_body(out, type);
      path_.erase(&type);
    }
    out.end_object();
  }

  void well_known_schema(JsonWriter& out, const gp::Descriptor& type) {
    const std::string& name = type.full_name();
    if (travels_as_json_text(type)) {
      json_text(out, name);
      return;
    }
    if (const FD* wrapped = type.FindFieldByName("value");
        wrapped != nullptr && type.field_count() == 1 && name.size() > 5 && name.rfind("Value") == name.size() - 5) {
      // google.protobuf.DoubleValue etc. print as their bare value (absent when unset).
      single_schema(out, *wrapped, false);
      return;
    }
    out.begin_object().key("title").value(name);
    if (name == "google.protobuf.Timestamp") {
      out.key("type").value("string").key("format").value("date-time");
    } else if (name == "google.protobuf.Duration" || name == "google.protobuf.FieldMask") {
      out.key("type").value("string");
    } else if (name == "google.protobuf.Empty") {
      out.key("type").value("object").key("properties").begin_object().end_object();
      out.key("additionalProperties").value(false);
    } else if (name == "google.protobuf.Any") {
      out.key("type").value("object").key("properties").begin_object();
      out.key("@type").begin_object().key("type").value("string").end_object();
      out.end_object();
    } else {
      // google.protobuf.Struct, and any other: an object of any members.
      out.key("type").value("object").key("properties").begin_object().end_object();
    }
    out.end_object();
  }

  std::set<const gp::Descriptor*> path_;  // the message types being written, outermost first
};

}  // namespace

std::string json_schema(const gp::Descriptor& type) { return SchemaBuilder().build(type); }

}  // namespace urs::gateway
