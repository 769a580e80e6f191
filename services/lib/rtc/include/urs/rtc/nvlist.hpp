#pragma once
// SDOPackage::NVList (sequence of {string name; any value}) as the RT side uses it: connector
// and port properties are strings; data ports also carry object references.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "SDOPackage.hh"

namespace urs::rtc {

// The value under `name` if it holds a string; nullopt if absent or of another type.
std::optional<std::string> nv_string(const SDOPackage::NVList& list, const std::string& name);
// The object reference under `name` (caller owns); nil if absent or not an object reference.
CORBA::Object_ptr nv_object(const SDOPackage::NVList& list, const std::string& name);
bool nv_has(const SDOPackage::NVList& list, const std::string& name);

// Sets (replacing an existing entry) or appends `name`.
void nv_set(SDOPackage::NVList& list, const std::string& name, const std::string& value);
void nv_set_object(SDOPackage::NVList& list, const std::string& name, CORBA::Object_ptr object);
void nv_append(SDOPackage::NVList& list, const SDOPackage::NVList& more);  // replaces same names
SDOPackage::NVList nv_from(const std::vector<std::pair<std::string, std::string>>& pairs);

// A value shown to a person: strings as they are, numbers and booleans in decimal, object
// references as "<object reference>", anything else as "<type id or kind>".
std::string any_to_text(const CORBA::Any& value);

// "key=value" per entry (values through any_to_text), in list order.
std::vector<std::string> nv_lines(const SDOPackage::NVList& list);

}  // namespace urs::rtc
