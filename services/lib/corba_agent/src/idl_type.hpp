#pragma once
// The IDL types the Planet translator writes into the idl_type field option, parsed once per
// field, and the other options a converter reads (docs/idl-mapping.md §3 and §5).

#include <google/protobuf/descriptor.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "urs_options.pb.h"

namespace urs::corba_agent::detail {

struct IdlType {
  enum class Kind {
    kBoolean,
    kChar,
    kWChar,
    kOctet,
    kShort,
    kUShort,
    kLong,
    kULong,
    kLongLong,
    kULongLong,
    kFloat,
    kDouble,
    kString,
    kWString,
    kSequence,
    kNamed
  };
  Kind kind = Kind::kLong;
  std::uint32_t bound = 0;                 // string, wstring, sequence: 0 is unbounded
  std::shared_ptr<const IdlType> element;  // sequence
  std::vector<std::uint32_t> dims;         // an array type named inside a sequence: "long[4]"
  std::string name;                        // kNamed: "::URC::Pose2D"

  bool is_octet_sequence() const {
    return kind == Kind::kSequence && element->kind == Kind::kOctet && element->dims.empty();
  }
};

// Throws std::invalid_argument naming the spelling if it is not one the translator writes.
std::shared_ptr<const IdlType> parse_idl_type(const std::string& spelling);

inline urs::options::MessageKind message_kind(const google::protobuf::Descriptor& message) {
  return message.options().GetExtension(urs::options::message_kind);
}

// A field whose values are generated wrapper messages: each value is the wrapper's `items` field.
inline bool is_wrapper(const google::protobuf::FieldDescriptor& field) {
  return field.message_type() != nullptr && message_kind(*field.message_type()) == urs::options::MESSAGE_KIND_WRAPPER;
}

inline const google::protobuf::FieldDescriptor& wrapper_items(const google::protobuf::FieldDescriptor& field) {
  return *field.message_type()->field(0);
}

std::vector<std::uint32_t> array_dims(const google::protobuf::FieldDescriptor& field);

// The union's discriminator field, or nullptr if `message` is not a union.
const google::protobuf::FieldDescriptor* union_discriminator(const google::protobuf::Descriptor& message);

// The discriminator value a union case label stands for ("1", "'a'", "TRUE", "RED"), as the
// integer the converter compares: enum ordinals, character codes, 0/1 for booleans.
// Throws std::invalid_argument for a label it cannot read.
std::int64_t label_value(const google::protobuf::FieldDescriptor& discriminator, const std::string& label);

// The scoped name in a repository ID ("IDL:URC/Navigation:1.0" -> "URC::Navigation"); the text
// after the last '/' or ':' separators for IDs that are not of the IDL: form.
std::string scoped_name(const std::string& repository_id);

}  // namespace urs::corba_agent::detail
