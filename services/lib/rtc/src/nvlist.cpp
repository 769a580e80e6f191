#include "urs/rtc/nvlist.hpp"

namespace urs::rtc {
namespace {

const SDOPackage::NameValue* find(const SDOPackage::NVList& list, const std::string& name) {
  for (CORBA::ULong i = 0; i < list.length(); ++i) {
    if (name == list[i].name.in()) return &list[i];
  }
  return nullptr;
}

SDOPackage::NameValue& slot(SDOPackage::NVList& list, const std::string& name) {
  for (CORBA::ULong i = 0; i < list.length(); ++i) {
    if (name == list[i].name.in()) return list[i];
  }
  const CORBA::ULong n = list.length();
  list.length(n + 1);
  list[n].name = CORBA::string_dup(name.c_str());
  return list[n];
}

// The number `value` holds, as text, trying the types Numbers in turn; nullopt if it holds none.
template <typename... Numbers>
std::optional<std::string> number_text(const CORBA::Any& value) {
  std::optional<std::string> text;
  const auto extract = [&](auto number) {
    if (value >>= number) text = std::to_string(number);
    return text.has_value();
  };
  (extract(Numbers{}) || ...);
  return text;
}

}  // namespace

std::optional<std::string> nv_string(const SDOPackage::NVList& list, const std::string& name) {
  const SDOPackage::NameValue* entry = find(list, name);
  const char* text = nullptr;
  if (entry == nullptr || !(entry->value >>= text)) return std::nullopt;
  return std::string(text);
}

CORBA::Object_ptr nv_object(const SDOPackage::NVList& list, const std::string& name) {
  const SDOPackage::NameValue* entry = find(list, name);
  CORBA::Object_ptr object = CORBA::Object::_nil();
  if (entry == nullptr || !(entry->value >>= CORBA::Any::to_object(object))) return CORBA::Object::_nil();
  return object;  // to_object extraction gives the caller a duplicate
}

bool nv_has(const SDOPackage::NVList& list, const std::string& name) { return find(list, name) != nullptr; }

void nv_set(SDOPackage::NVList& list, const std::string& name, const std::string& value) {
  slot(list, name).value <<= value.c_str();
}

void nv_set_object(SDOPackage::NVList& list, const std::string& name, CORBA::Object_ptr object) {
  slot(list, name).value <<= object;  // copying insertion
}

void nv_append(SDOPackage::NVList& list, const SDOPackage::NVList& more) {
  for (CORBA::ULong i = 0; i < more.length(); ++i) slot(list, more[i].name.in()).value = more[i].value;
}

SDOPackage::NVList nv_from(const std::vector<std::pair<std::string, std::string>>& pairs) {
  SDOPackage::NVList list;
  for (const auto& [name, value] : pairs) nv_set(list, name, value);
  return list;
}

std::string any_to_text(const CORBA::Any& value) {
  const char* text = nullptr;
  if (value >>= text) return text;
  const auto number =
      number_text<CORBA::Long, CORBA::ULong, CORBA::LongLong, CORBA::Short, CORBA::Double, CORBA::Float>(value);
  if (number) return *number;
  CORBA::Boolean b = false;
  if (value >>= CORBA::Any::to_boolean(b)) return b ? "true" : "false";
  CORBA::TypeCode_var type = value.type();
  if (type->kind() == CORBA::tk_objref) return "<object reference>";
  if (type->kind() == CORBA::tk_null || type->kind() == CORBA::tk_void) return "";
  try {
    return std::string("<") + type->id() + ">";
  } catch (const CORBA::TypeCode::BadKind&) {
    return "<value of kind " + std::to_string(static_cast<int>(type->kind())) + ">";
  }
}

std::vector<std::string> nv_lines(const SDOPackage::NVList& list) {
  std::vector<std::string> lines;
  for (CORBA::ULong i = 0; i < list.length(); ++i) {
    lines.push_back(std::string(list[i].name.in()) + "=" + any_to_text(list[i].value));
  }
  return lines;
}

}  // namespace urs::rtc
