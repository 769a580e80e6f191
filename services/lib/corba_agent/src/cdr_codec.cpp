#include "urs/corba_agent/cdr_codec.hpp"

#include <algorithm>
#include <deque>
#include <limits>
#include <optional>
#include <unordered_map>

#include "idl_type.hpp"
#include "utf8.hpp"

namespace urs::corba_agent {

using detail::IdlType;
using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::OneofDescriptor;
using google::protobuf::Reflection;
using Kind = IdlType::Kind;

ConversionError::ConversionError(std::string path, std::string reason)
    : std::runtime_error(path.empty() ? reason : path + ": " + reason),
      path_(std::move(path)),
      reason_(std::move(reason)) {}

ConversionError ConversionError::within(const std::string& outer) const {
  if (path_.empty()) return {outer, reason_};
  return {outer + (path_.front() == '[' ? "" : ".") + path_, reason_};
}

namespace {

struct FieldPlan {
  const FieldDescriptor* field = nullptr;
  std::shared_ptr<const IdlType> type;
  std::uint64_t array_size = 0;  // product of array_dims; 0: not an array
  bool wrapper = false;          // each value is a wrapper message holding it in `items`
};

struct UnionPlan {
  const FieldDescriptor* discriminator = nullptr;
  const OneofDescriptor* branches = nullptr;
  std::vector<std::pair<std::int64_t, const FieldDescriptor*>> cases;
  const FieldDescriptor* default_branch = nullptr;

  // The branch a discriminator value selects; nullptr for none.
  const FieldDescriptor* select(std::int64_t value) const {
    for (const auto& [label, branch] : cases) {
      if (label == value) return branch;
    }
    return default_branch;
  }
};

struct MessagePlan {
  std::vector<const FieldPlan*> fields;
  std::optional<UnionPlan> union_plan;
};

std::string branch_name(const FieldDescriptor* branch) { return branch ? "'" + branch->name() + "'" : "none"; }

}  // namespace

struct CdrCodec::Plans {
  std::unordered_map<const FieldDescriptor*, FieldPlan> fields;  // node-based: plans never move
  std::unordered_map<const Descriptor*, MessagePlan> messages;

  const MessagePlan& message(const Descriptor& type) const {
    const auto it = messages.find(&type);
    if (it == messages.end()) throw std::invalid_argument(type.full_name() + " is not a type this codec was built for");
    return it->second;
  }
  const FieldPlan& field(const FieldDescriptor& field) const {
    const auto it = fields.find(&field);
    if (it == fields.end()) throw std::invalid_argument(field.full_name() + " is not a field this codec was built for");
    return it->second;
  }

  void add(const Descriptor& root) {
    std::deque<const Descriptor*> pending{&root};
    while (!pending.empty()) {
      const Descriptor* type = pending.front();
      pending.pop_front();
      if (messages.count(type) != 0) continue;
      MessagePlan& plan = messages[type];
      for (int i = 0; i < type->field_count(); ++i) {
        const FieldDescriptor* field = type->field(i);
        plan.fields.push_back(&add_field(*field));
        if (field->message_type() != nullptr) pending.push_back(field->message_type());
      }
      if (const auto* discriminator = detail::union_discriminator(*type))
        plan.union_plan = union_plan(*type, *discriminator);
    }
  }

 private:
  const FieldPlan& add_field(const FieldDescriptor& field) {
    const auto& options = field.options();
    if (!options.HasExtension(urs::options::idl_type)) {
      throw std::invalid_argument(field.full_name() + " has no idl_type option: not generated from IDL");
    }
    FieldPlan plan;
    plan.field = &field;
    try {
      plan.type = detail::parse_idl_type(options.GetExtension(urs::options::idl_type));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(field.full_name() + ": " + e.what());
    }
    plan.wrapper = detail::is_wrapper(field);
    const auto dims = detail::array_dims(field);
    if (!dims.empty()) {
      plan.array_size = 1;
      for (auto d : dims) plan.array_size *= d;
    }
    if (plan.type->kind == Kind::kNamed && !plan.wrapper && field.message_type() == nullptr &&
        field.enum_type() == nullptr) {
      throw std::invalid_argument(field.full_name() + ": idl_type names " + plan.type->name +
                                  " but the field is neither a message nor an enum");
    }
    return fields[&field] = std::move(plan);
  }

  static UnionPlan union_plan(const Descriptor& type, const FieldDescriptor& discriminator) {
    UnionPlan plan;
    plan.discriminator = &discriminator;
    if (type.oneof_decl_count() == 0) return plan;  // a union with no branch is legal if useless
    plan.branches = type.oneof_decl(0);
    for (int i = 0; i < plan.branches->field_count(); ++i) {
      const FieldDescriptor* branch = plan.branches->field(i);
      const auto& options = branch->options();
      if (options.GetExtension(urs::options::default_case)) plan.default_branch = branch;
      for (int j = 0; j < options.ExtensionSize(urs::options::case_labels); ++j) {
        plan.cases.emplace_back(detail::label_value(discriminator, options.GetExtension(urs::options::case_labels, j)),
                                branch);
      }
    }
    return plan;
  }
};

namespace {

// The discriminator as the integer case labels are compared with.
std::int64_t discriminator_value(const Message& message, const FieldDescriptor& field) {
  const Reflection* r = message.GetReflection();
  switch (field.cpp_type()) {
    case FieldDescriptor::CPPTYPE_BOOL:
      return r->GetBool(message, &field) ? 1 : 0;
    case FieldDescriptor::CPPTYPE_ENUM:
      return r->GetEnumValue(message, &field);
    case FieldDescriptor::CPPTYPE_INT32:
      return r->GetInt32(message, &field);
    case FieldDescriptor::CPPTYPE_UINT32:
      return r->GetUInt32(message, &field);
    case FieldDescriptor::CPPTYPE_INT64:
      return r->GetInt64(message, &field);
    case FieldDescriptor::CPPTYPE_UINT64:
      return static_cast<std::int64_t>(r->GetUInt64(message, &field));
    case FieldDescriptor::CPPTYPE_STRING: {  // char
      const auto points = detail::utf8_to_code_points(r->GetString(message, &field));
      if (!points || points->size() != 1)
        throw ConversionError(field.name(), "a char discriminator must be one character");
      return (*points)[0];
    }
    default:
      throw ConversionError(field.name(), "unsupported discriminator type");
  }
}

void check_bound(std::size_t size, std::uint32_t bound, const char* what) {
  if (bound != 0 && size > bound) {
    throw ConversionError(
        "", std::string(what) + " of " + std::to_string(size) + " is over the bound of " + std::to_string(bound));
  }
}

template <typename T>
T checked_range(std::int64_t value, const char* type) {
  if (value < std::numeric_limits<T>::min() || value > std::numeric_limits<T>::max()) {
    throw ConversionError("", std::string(type) + " value " + std::to_string(value) + " is out of range " +
                                  std::to_string(std::numeric_limits<T>::min()) + ".." +
                                  std::to_string(std::numeric_limits<T>::max()));
  }
  return static_cast<T>(value);
}

std::string index_segment(int index) { return "[" + std::to_string(index) + "]"; }

// Reads a field's value at `index` (-1: the singular value) through reflection.
struct Get {
  const Message& m;
  const FieldDescriptor* f;
  int index;
  const Reflection* r = m.GetReflection();

  std::int32_t int32() const { return index < 0 ? r->GetInt32(m, f) : r->GetRepeatedInt32(m, f, index); }
  std::uint32_t uint32() const { return index < 0 ? r->GetUInt32(m, f) : r->GetRepeatedUInt32(m, f, index); }
  std::int64_t int64() const { return index < 0 ? r->GetInt64(m, f) : r->GetRepeatedInt64(m, f, index); }
  std::uint64_t uint64() const { return index < 0 ? r->GetUInt64(m, f) : r->GetRepeatedUInt64(m, f, index); }
  float floating() const { return index < 0 ? r->GetFloat(m, f) : r->GetRepeatedFloat(m, f, index); }
  double dbl() const { return index < 0 ? r->GetDouble(m, f) : r->GetRepeatedDouble(m, f, index); }
  bool boolean() const { return index < 0 ? r->GetBool(m, f) : r->GetRepeatedBool(m, f, index); }
  int enumeration() const { return index < 0 ? r->GetEnumValue(m, f) : r->GetRepeatedEnumValue(m, f, index); }
  const std::string& string(std::string& scratch) const {
    return index < 0 ? r->GetStringReference(m, f, &scratch) : r->GetRepeatedStringReference(m, f, index, &scratch);
  }
  const Message& message() const { return index < 0 ? r->GetMessage(m, f) : r->GetRepeatedMessage(m, f, index); }
};

// Stores a value into a field: sets the singular value, or appends to a repeated field.
struct Put {
  Message& m;
  const FieldDescriptor* f;
  bool append;
  const Reflection* r = m.GetReflection();

  void int32(std::int32_t v) const { append ? r->AddInt32(&m, f, v) : r->SetInt32(&m, f, v); }
  void uint32(std::uint32_t v) const { append ? r->AddUInt32(&m, f, v) : r->SetUInt32(&m, f, v); }
  void int64(std::int64_t v) const { append ? r->AddInt64(&m, f, v) : r->SetInt64(&m, f, v); }
  void uint64(std::uint64_t v) const { append ? r->AddUInt64(&m, f, v) : r->SetUInt64(&m, f, v); }
  void floating(float v) const { append ? r->AddFloat(&m, f, v) : r->SetFloat(&m, f, v); }
  void dbl(double v) const { append ? r->AddDouble(&m, f, v) : r->SetDouble(&m, f, v); }
  void boolean(bool v) const { append ? r->AddBool(&m, f, v) : r->SetBool(&m, f, v); }
  void enumeration(int v) const { append ? r->AddEnumValue(&m, f, v) : r->SetEnumValue(&m, f, v); }
  void string(std::string v) const { append ? r->AddString(&m, f, std::move(v)) : r->SetString(&m, f, std::move(v)); }
  Message& message() const { return append ? *r->AddMessage(&m, f) : *r->MutableMessage(&m, f); }
};

class Writer {
 public:
  Writer(const CdrCodec::Plans& plans, cdrStream& stream) : plans_(plans), s_(stream) {}

  void message(const Message& m) {
    const MessagePlan& plan = plans_.message(*m.GetDescriptor());
    if (plan.union_plan) return union_value(m, *plan.union_plan);
    for (const FieldPlan* field : plan.fields) this->field(m, *field);
  }

  void field(const Message& m, const FieldPlan& p) {
    try {
      field_body(m, p);
    } catch (const ConversionError& e) {
      throw e.within(p.field->name());
    }
  }

 private:
  void field_body(const Message& m, const FieldPlan& p) {
    if (p.array_size == 0) return value(*p.type, m, p, -1);
    const FieldDescriptor* f = p.field;
    if (f->type() == FieldDescriptor::TYPE_BYTES && p.type->kind == Kind::kOctet) {
      std::string scratch;
      const std::string& bytes = Get{m, f, -1}.string(scratch);
      if (bytes.size() != p.array_size) {
        throw ConversionError(
            "", "holds " + std::to_string(bytes.size()) + " octets; the array has " + std::to_string(p.array_size));
      }
      s_.put_octet_array(reinterpret_cast<const CORBA::Octet*>(bytes.data()), static_cast<int>(bytes.size()));
      return;
    }
    const int size = m.GetReflection()->FieldSize(m, f);
    if (static_cast<std::uint64_t>(size) != p.array_size) {
      throw ConversionError(
          "", "holds " + std::to_string(size) + " elements; the array has " + std::to_string(p.array_size));
    }
    for (int i = 0; i < size; ++i) element(*p.type, m, p, i);
  }

  void element(const IdlType& t, const Message& m, const FieldPlan& p, int index) {
    try {
      value(t, m, p, index);
    } catch (const ConversionError& e) {
      throw e.within(index_segment(index));
    }
  }

  void value(const IdlType& t, const Message& m, const FieldPlan& p, int index) {
    const FieldDescriptor* f = p.field;
    if (p.wrapper && (index >= 0 || !f->is_repeated())) {
      const Message& wrapper = Get{m, f, index}.message();
      return field_body(wrapper, plans_.field(detail::wrapper_items(*f)));
    }
    const Get get{m, f, index};
    std::string scratch;
    switch (t.kind) {
      case Kind::kBoolean:
        return s_.marshalBoolean(get.boolean());
      case Kind::kOctet:
        return s_.marshalOctet(checked_range<CORBA::Octet>(get.uint32(), "octet"));
      case Kind::kShort:
        checked_range<CORBA::Short>(get.int32(), "short") >>= s_;
        return;
      case Kind::kUShort:
        checked_range<CORBA::UShort>(get.uint32(), "unsigned short") >>= s_;
        return;
      case Kind::kLong:
        CORBA::Long(get.int32()) >>= s_;
        return;
      case Kind::kULong:
        CORBA::ULong(get.uint32()) >>= s_;
        return;
      case Kind::kLongLong:
        CORBA::LongLong(get.int64()) >>= s_;
        return;
      case Kind::kULongLong:
        CORBA::ULongLong(get.uint64()) >>= s_;
        return;
      case Kind::kFloat:
        CORBA::Float(get.floating()) >>= s_;
        return;
      case Kind::kDouble:
        CORBA::Double(get.dbl()) >>= s_;
        return;
      case Kind::kChar:
        return s_.marshalChar(static_cast<CORBA::Char>(one_character(get.string(scratch), 0xFF, "char")));
      case Kind::kWChar:
        return s_.marshalWChar(static_cast<CORBA::WChar>(one_character(get.string(scratch), 0x10FFFF, "wchar")));
      case Kind::kString: {
        const std::string& text = get.string(scratch);
        check_bound(text.size(), t.bound, "a string");
        if (text.find('\0') != std::string::npos)
          throw ConversionError("", "a CORBA string cannot hold a NUL character");
        return s_.marshalString(text.c_str());
      }
      case Kind::kWString: {
        const auto points = detail::utf8_to_code_points(get.string(scratch));
        if (!points) throw ConversionError("", "not valid UTF-8");
        check_bound(points->size(), t.bound, "a wstring");
        std::vector<CORBA::WChar> wide(points->begin(), points->end());
        if (std::find(wide.begin(), wide.end(), 0) != wide.end()) {
          throw ConversionError("", "a CORBA wstring cannot hold a NUL character");
        }
        wide.push_back(0);
        return s_.marshalWString(wide.data());
      }
      case Kind::kSequence:
        return sequence(t, m, p, index);
      case Kind::kNamed:
        if (f->message_type() != nullptr) return message(get.message());
        return enumeration(*f->enum_type(), get.enumeration());
    }
  }

  void sequence(const IdlType& t, const Message& m, const FieldPlan& p, int index) {
    if (t.is_octet_sequence()) {
      std::string scratch;
      const std::string& bytes = Get{m, p.field, index}.string(scratch);
      check_bound(bytes.size(), t.bound, "a sequence length");
      CORBA::ULong(bytes.size()) >>= s_;
      s_.put_octet_array(reinterpret_cast<const CORBA::Octet*>(bytes.data()), static_cast<int>(bytes.size()));
      return;
    }
    const int size = m.GetReflection()->FieldSize(m, p.field);
    check_bound(static_cast<std::size_t>(size), t.bound, "a sequence length");
    CORBA::ULong(size) >>= s_;
    for (int i = 0; i < size; ++i) element(*t.element, m, p, i);
  }

  void enumeration(const google::protobuf::EnumDescriptor& type, int number) {
    if (type.FindValueByNumber(number) == nullptr) {
      throw ConversionError("", std::to_string(number) + " is not a value of enum " + type.full_name());
    }
    CORBA::ULong(number) >>= s_;
  }

  static std::uint32_t one_character(const std::string& text, std::uint32_t max, const char* type) {
    const auto points = detail::utf8_to_code_points(text);
    if (!points || points->size() != 1 || (*points)[0] > max) {
      throw ConversionError("", std::string("a ") + type + " must be exactly one character" +
                                    (max == 0xFF ? " of ISO 8859-1" : "") + ", not '" + text + "'");
    }
    return (*points)[0];
  }

  void union_value(const Message& m, const UnionPlan& plan) {
    const std::int64_t d = discriminator_value(m, *plan.discriminator);
    const FieldDescriptor* selected = plan.select(d);
    const FieldDescriptor* set = plan.branches ? m.GetReflection()->GetOneofFieldDescriptor(m, plan.branches) : nullptr;
    if (set != selected) {
      throw ConversionError(plan.discriminator->name(), "the discriminator " + std::to_string(d) + " selects branch " +
                                                            branch_name(selected) + " but the branch set is " +
                                                            branch_name(set));
    }
    field(m, plans_.field(*plan.discriminator));
    if (selected != nullptr) field(m, plans_.field(*selected));
  }

  const CdrCodec::Plans& plans_;
  cdrStream& s_;
};

class Reader {
 public:
  Reader(const CdrCodec::Plans& plans, cdrStream& stream) : plans_(plans), s_(stream) {}

  void message(Message& m) {
    const MessagePlan& plan = plans_.message(*m.GetDescriptor());
    if (plan.union_plan) return union_value(m, *plan.union_plan);
    for (const FieldPlan* field : plan.fields) this->field(m, *field);
  }

  void field(Message& m, const FieldPlan& p) {
    try {
      field_body(m, p);
    } catch (const ConversionError& e) {
      throw e.within(p.field->name());
    }
  }

 private:
  void field_body(Message& m, const FieldPlan& p) {
    if (p.array_size == 0) return value(*p.type, m, p, false);
    if (p.field->type() == FieldDescriptor::TYPE_BYTES && p.type->kind == Kind::kOctet) {
      return Put{m, p.field, false}.string(octets(static_cast<CORBA::ULong>(p.array_size)));
    }
    for (std::uint64_t i = 0; i < p.array_size; ++i) element(*p.type, m, p, i);
  }

  void element(const IdlType& t, Message& m, const FieldPlan& p, std::uint64_t index) {
    try {
      value(t, m, p, true);
    } catch (const ConversionError& e) {
      throw e.within(index_segment(static_cast<int>(index)));
    }
  }

  void value(const IdlType& t, Message& m, const FieldPlan& p, bool append) {
    const FieldDescriptor* f = p.field;
    const Put put{m, f, append};
    if (p.wrapper && (append || !f->is_repeated()))
      return field_body(put.message(), plans_.field(detail::wrapper_items(*f)));
    switch (t.kind) {
      case Kind::kBoolean:
        return put.boolean(s_.unmarshalBoolean());
      case Kind::kOctet:
        return put.uint32(s_.unmarshalOctet());
      case Kind::kShort:
        return put.int32(read<CORBA::Short>());
      case Kind::kUShort:
        return put.uint32(read<CORBA::UShort>());
      case Kind::kLong:
        return put.int32(read<CORBA::Long>());
      case Kind::kULong:
        return put.uint32(read<CORBA::ULong>());
      case Kind::kLongLong:
        return put.int64(read<CORBA::LongLong>());
      case Kind::kULongLong:
        return put.uint64(read<CORBA::ULongLong>());
      case Kind::kFloat:
        return put.floating(read<CORBA::Float>());
      case Kind::kDouble:
        return put.dbl(read<CORBA::Double>());
      case Kind::kChar:
        return put.string(detail::code_points_to_utf8({s_.unmarshalChar()}));
      case Kind::kWChar:
        return put.string(detail::code_points_to_utf8({static_cast<std::uint32_t>(s_.unmarshalWChar())}));
      case Kind::kString: {
        CORBA::String_var text = s_.unmarshalString();
        std::string value(text.in());
        check_bound(value.size(), t.bound, "a string");
        return put.string(std::move(value));
      }
      case Kind::kWString: {
        CORBA::WString_var text = s_.unmarshalWString();
        std::vector<std::uint32_t> points;
        for (const CORBA::WChar* c = text.in(); *c != 0; ++c) points.push_back(static_cast<std::uint32_t>(*c));
        check_bound(points.size(), t.bound, "a wstring");
        return put.string(detail::code_points_to_utf8(points));
      }
      case Kind::kSequence:
        return sequence(t, m, p, append);
      case Kind::kNamed:
        if (f->message_type() != nullptr) return message(put.message());
        return put.enumeration(enumeration(*f->enum_type()));
    }
  }

  void sequence(const IdlType& t, Message& m, const FieldPlan& p, bool append) {
    const CORBA::ULong length = read<CORBA::ULong>();
    check_bound(length, t.bound, "a sequence length");
    if (t.is_octet_sequence()) return Put{m, p.field, append}.string(octets(length));
    if (!s_.checkInputOverrun(1, length)) throw CORBA::MARSHAL(0, CORBA::COMPLETED_NO);
    for (CORBA::ULong i = 0; i < length; ++i) element(*t.element, m, p, i);
  }

  std::string octets(CORBA::ULong length) {
    if (!s_.checkInputOverrun(1, length)) throw CORBA::MARSHAL(0, CORBA::COMPLETED_NO);
    std::string bytes(length, '\0');
    s_.get_octet_array(reinterpret_cast<CORBA::Octet*>(bytes.data()), static_cast<int>(length));
    return bytes;
  }

  int enumeration(const google::protobuf::EnumDescriptor& type) {
    const CORBA::ULong number = read<CORBA::ULong>();
    if (number > static_cast<CORBA::ULong>(std::numeric_limits<int>::max()) ||
        type.FindValueByNumber(static_cast<int>(number)) == nullptr) {
      throw ConversionError("", std::to_string(number) + " is not a value of enum " + type.full_name());
    }
    return static_cast<int>(number);
  }

  template <typename T>
  T read() {
    T value;
    value <<= s_;
    return value;
  }

  void union_value(Message& m, const UnionPlan& plan) {
    field(m, plans_.field(*plan.discriminator));
    if (const FieldDescriptor* selected = plan.select(discriminator_value(m, *plan.discriminator))) {
      field(m, plans_.field(*selected));
    }
  }

  const CdrCodec::Plans& plans_;
  cdrStream& s_;
};

}  // namespace

CdrCodec::CdrCodec(const std::vector<const Descriptor*>& roots) : plans_(std::make_unique<Plans>()) {
  for (const Descriptor* root : roots) plans_->add(*root);
}

CdrCodec::~CdrCodec() = default;

void CdrCodec::write(cdrStream& stream, const Message& message) const {
  try {
    Writer(*plans_, stream).message(message);
  } catch (const ConversionError& e) {
    throw e.within(message.GetDescriptor()->full_name());
  }
}

void CdrCodec::read(cdrStream& stream, Message& message) const {
  try {
    Reader(*plans_, stream).message(message);
  } catch (const ConversionError& e) {
    throw e.within(message.GetDescriptor()->full_name());
  }
}

void CdrCodec::write_field(cdrStream& stream, const Message& message, const FieldDescriptor& field) const {
  try {
    Writer(*plans_, stream).field(message, plans_->field(field));
  } catch (const ConversionError& e) {
    throw e.within(message.GetDescriptor()->full_name());
  }
}

void CdrCodec::read_field(cdrStream& stream, Message& message, const FieldDescriptor& field) const {
  try {
    Reader(*plans_, stream).field(message, plans_->field(field));
  } catch (const ConversionError& e) {
    throw e.within(message.GetDescriptor()->full_name());
  }
}

}  // namespace urs::corba_agent
