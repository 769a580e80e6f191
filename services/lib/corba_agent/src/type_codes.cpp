#include "urs/corba_agent/type_codes.hpp"

#include <stdexcept>

#include "idl_type.hpp"

namespace urs::corba_agent {

using detail::IdlType;
using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using Kind = IdlType::Kind;

namespace {

CORBA::TypeCode_ptr primitive(Kind kind) {
  switch (kind) {
    case Kind::kBoolean:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_boolean);
    case Kind::kChar:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_char);
    case Kind::kWChar:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_wchar);
    case Kind::kOctet:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_octet);
    case Kind::kShort:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_short);
    case Kind::kUShort:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_ushort);
    case Kind::kLong:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_long);
    case Kind::kULong:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_ulong);
    case Kind::kLongLong:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_longlong);
    case Kind::kULongLong:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_ulonglong);
    case Kind::kFloat:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_float);
    case Kind::kDouble:
      return CORBA::TypeCode::_duplicate(CORBA::_tc_double);
    default:
      return CORBA::TypeCode::_nil();
  }
}

// The last component of the scoped name in a repository ID: a TypeCode's name.
std::string simple_name(const std::string& repository_id) {
  const std::string scoped = detail::scoped_name(repository_id);
  const auto colons = scoped.rfind("::");
  return colons == std::string::npos ? scoped : scoped.substr(colons + 2);
}

void marshal_ulong(cdrStream& stream, void* value) { *static_cast<CORBA::ULong*>(value) >>= stream; }

// A union case label as an Any of the discriminator's type.
CORBA::Any label_any(const IdlType& discriminator, CORBA::TypeCode_ptr discriminator_type, std::int64_t value) {
  CORBA::Any any;
  switch (discriminator.kind) {
    case Kind::kBoolean:
      any <<= CORBA::Any::from_boolean(value != 0);
      break;
    case Kind::kChar:
      any <<= CORBA::Any::from_char(static_cast<CORBA::Char>(value));
      break;
    case Kind::kShort:
      any <<= static_cast<CORBA::Short>(value);
      break;
    case Kind::kUShort:
      any <<= static_cast<CORBA::UShort>(value);
      break;
    case Kind::kLong:
      any <<= static_cast<CORBA::Long>(value);
      break;
    case Kind::kULong:
      any <<= static_cast<CORBA::ULong>(value);
      break;
    case Kind::kLongLong:
      any <<= static_cast<CORBA::LongLong>(value);
      break;
    case Kind::kULongLong:
      any <<= static_cast<CORBA::ULongLong>(value);
      break;
    case Kind::kNamed: {  // an enum: its ordinal, under the enum's TypeCode
      CORBA::ULong ordinal = static_cast<CORBA::ULong>(value);
      any.PR_insert(discriminator_type, marshal_ulong, &ordinal);
      break;
    }
    default:
      throw std::invalid_argument("unsupported union discriminator type");
  }
  return any;
}

}  // namespace

CORBA::TypeCode_ptr TypeCodes::field(const FieldDescriptor& field) {
  std::shared_ptr<const IdlType> type;
  try {
    type = detail::parse_idl_type(field.options().GetExtension(urs::options::idl_type));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(field.full_name() + ": " + e.what());
  }
  // `element`: describing one value of a repeated field (or a union branch), which a wrapper holds
  // when it is itself a sequence or an array.
  const auto value = [&](const auto& self, const IdlType& t, bool element) -> CORBA::TypeCode_ptr {
    if (detail::is_wrapper(field) && (element || !field.is_repeated()))
      return this->field(detail::wrapper_items(field));
    switch (t.kind) {
      case Kind::kString:
        return t.bound ? orb_->create_string_tc(t.bound) : CORBA::TypeCode::_duplicate(CORBA::_tc_string);
      case Kind::kWString:
        return t.bound ? orb_->create_wstring_tc(t.bound) : CORBA::TypeCode::_duplicate(CORBA::_tc_wstring);
      case Kind::kSequence: {
        CORBA::TypeCode_var element_type = self(self, *t.element, true);
        return orb_->create_sequence_tc(t.bound, element_type);
      }
      case Kind::kNamed:
        if (field.message_type() != nullptr) return message(*field.message_type());
        if (field.enum_type() != nullptr) return enumeration(*field.enum_type());
        throw std::invalid_argument(field.full_name() + ": " + t.name + " is neither a message nor an enum");
      default:
        return primitive(t.kind);
    }
  };
  const auto dims = detail::array_dims(field);
  CORBA::TypeCode_var tc = value(value, *type, !dims.empty());
  for (auto d = dims.rbegin(); d != dims.rend(); ++d) tc = orb_->create_array_tc(*d, tc);
  return tc._retn();
}

CORBA::TypeCode_ptr TypeCodes::message(const Descriptor& message) {
  if (auto it = messages_.find(&message); it != messages_.end()) return CORBA::TypeCode::_duplicate(it->second);
  const std::string id = message.options().GetExtension(urs::options::message_repository_id);
  if (id.empty())
    throw std::invalid_argument(message.full_name() + " has no repository ID: not an IDL struct, exception or union");
  if (building_.count(&message) != 0) return orb_->create_recursive_tc(id.c_str());
  building_.insert(&message);
  const std::string name = simple_name(id);
  CORBA::TypeCode_var tc;
  const auto kind = detail::message_kind(message);
  if (kind == urs::options::MESSAGE_KIND_UNION) {
    const FieldDescriptor* discriminator = detail::union_discriminator(message);
    if (discriminator == nullptr)
      throw std::invalid_argument(message.full_name() + ": a union without a discriminator");
    CORBA::TypeCode_var discriminator_type = field(*discriminator);
    const auto discriminator_idl =
        detail::parse_idl_type(discriminator->options().GetExtension(urs::options::idl_type));
    CORBA::UnionMemberSeq members;
    const auto add = [&](const FieldDescriptor& branch, CORBA::Any label) {
      const CORBA::ULong i = members.length();
      members.length(i + 1);
      members[i].name = branch.name().c_str();
      members[i].label = label;
      members[i].type = field(branch);
    };
    for (int b = 0; message.oneof_decl_count() > 0 && b < message.oneof_decl(0)->field_count(); ++b) {
      const FieldDescriptor& branch = *message.oneof_decl(0)->field(b);
      const auto& options = branch.options();
      for (int l = 0; l < options.ExtensionSize(urs::options::case_labels); ++l) {
        const auto value = detail::label_value(*discriminator, options.GetExtension(urs::options::case_labels, l));
        add(branch, label_any(*discriminator_idl, discriminator_type, value));
      }
      if (options.GetExtension(urs::options::default_case)) {
        CORBA::Any default_label;  // the default branch is labelled with the octet 0
        default_label <<= CORBA::Any::from_octet(0);
        add(branch, default_label);
      }
    }
    tc = orb_->create_union_tc(id.c_str(), name.c_str(), discriminator_type, members);
  } else if (kind == urs::options::MESSAGE_KIND_STRUCT || kind == urs::options::MESSAGE_KIND_EXCEPTION) {
    CORBA::StructMemberSeq members;
    members.length(message.field_count());
    for (int i = 0; i < message.field_count(); ++i) {
      members[i].name = message.field(i)->name().c_str();
      members[i].type = field(*message.field(i));
    }
    tc = kind == urs::options::MESSAGE_KIND_STRUCT ? orb_->create_struct_tc(id.c_str(), name.c_str(), members)
                                                   : orb_->create_exception_tc(id.c_str(), name.c_str(), members);
  } else {
    throw std::invalid_argument(message.full_name() + " is not an IDL struct, exception or union");
  }
  building_.erase(&message);
  // A type built inside a recursive one may hold a recursive placeholder: keep only complete ones.
  if (building_.empty()) messages_[&message] = CORBA::TypeCode::_duplicate(tc);
  return tc._retn();
}

CORBA::TypeCode_ptr TypeCodes::enumeration(const google::protobuf::EnumDescriptor& enumeration) {
  const std::string id = enumeration.options().GetExtension(urs::options::enum_repository_id);
  CORBA::EnumMemberSeq members;
  members.length(enumeration.value_count());
  for (int i = 0; i < enumeration.value_count(); ++i) {
    const auto* value = enumeration.value(i);
    const std::string& idl_name = value->options().GetExtension(urs::options::idl_enumerator);
    members[i] = (idl_name.empty() ? value->name() : idl_name).c_str();
  }
  return orb_->create_enum_tc(id.c_str(), simple_name(id).c_str(), members);
}

}  // namespace urs::corba_agent
