#include "idl_type.hpp"

#include <cctype>
#include <map>
#include <stdexcept>

namespace urs::corba_agent::detail {
namespace {

using Kind = IdlType::Kind;

const std::map<std::string, Kind>& primitives() {
  static const std::map<std::string, Kind> table{
      {"boolean", Kind::kBoolean},    {"char", Kind::kChar},
      {"wchar", Kind::kWChar},        {"octet", Kind::kOctet},
      {"short", Kind::kShort},        {"unsigned short", Kind::kUShort},
      {"long", Kind::kLong},          {"unsigned long", Kind::kULong},
      {"long long", Kind::kLongLong}, {"unsigned long long", Kind::kULongLong},
      {"float", Kind::kFloat},        {"double", Kind::kDouble},
      {"string", Kind::kString},      {"wstring", Kind::kWString}};
  return table;
}

// Recursive descent over one spelling; `pos` moves past what each step reads.
class Parser {
 public:
  explicit Parser(const std::string& text) : text_(text) {}

  std::shared_ptr<const IdlType> parse() {
    auto type = type_at();
    skip_spaces();
    if (pos_ != text_.size()) fail("unexpected text after the type");
    return type;
  }

 private:
  std::shared_ptr<IdlType> type_at() {
    skip_spaces();
    auto type = std::make_shared<IdlType>();
    if (take("sequence<")) {
      type->kind = Kind::kSequence;
      type->element = type_at();
      skip_spaces();
      if (take(",")) type->bound = number();
      skip_spaces();
      if (!take(">")) fail("expected '>' closing the sequence");
    } else if (text_.compare(pos_, 2, "::") == 0) {
      type->kind = Kind::kNamed;
      const auto start = pos_;
      while (pos_ < text_.size() &&
             (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_' || text_[pos_] == ':')) {
        ++pos_;
      }
      type->name = text_.substr(start, pos_ - start);
    } else {
      primitive(*type);
    }
    while (take("[")) {
      type->dims.push_back(number());
      if (!take("]")) fail("expected ']'");
    }
    return type;
  }

  // The longest primitive spelling at pos ("unsigned long long" before "unsigned long").
  void primitive(IdlType& type) {
    std::size_t best = 0;
    for (const auto& [spelling, kind] : primitives()) {
      if (spelling.size() <= best || text_.compare(pos_, spelling.size(), spelling) != 0) continue;
      const std::size_t end = pos_ + spelling.size();
      if (end < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[end])) || text_[end] == '_')) continue;
      best = spelling.size();
      type.kind = kind;
    }
    if (best == 0) fail("unknown type");
    pos_ += best;
    if ((type.kind == Kind::kString || type.kind == Kind::kWString) && take("<")) {
      type.bound = number();
      if (!take(">")) fail("expected '>' closing the string bound");
    }
  }

  std::uint32_t number() {
    skip_spaces();
    const auto start = pos_;
    while (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    if (start == pos_) fail("expected a number");
    return static_cast<std::uint32_t>(std::stoul(text_.substr(start, pos_ - start)));
  }

  bool take(const char* token) {
    const std::string t(token);
    if (text_.compare(pos_, t.size(), t) != 0) return false;
    pos_ += t.size();
    return true;
  }
  void skip_spaces() {
    while (pos_ < text_.size() && text_[pos_] == ' ') ++pos_;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::invalid_argument("idl_type '" + text_ + "': " + what + " at offset " + std::to_string(pos_));
  }

  const std::string& text_;
  std::size_t pos_ = 0;
};

}  // namespace

std::shared_ptr<const IdlType> parse_idl_type(const std::string& spelling) { return Parser(spelling).parse(); }

std::vector<std::uint32_t> array_dims(const google::protobuf::FieldDescriptor& field) {
  const auto& options = field.options();
  std::vector<std::uint32_t> dims;
  for (int i = 0; i < options.ExtensionSize(urs::options::array_dims); ++i) {
    dims.push_back(options.GetExtension(urs::options::array_dims, i));
  }
  return dims;
}

const google::protobuf::FieldDescriptor* union_discriminator(const google::protobuf::Descriptor& message) {
  if (message_kind(message) != urs::options::MESSAGE_KIND_UNION || message.field_count() == 0) return nullptr;
  const auto* first = message.field(0);
  return first->options().GetExtension(urs::options::discriminator) ? first : nullptr;
}

std::int64_t label_value(const google::protobuf::FieldDescriptor& discriminator, const std::string& label) {
  const auto bad = [&] {
    return std::invalid_argument("union " + discriminator.containing_type()->full_name() + ": case label '" + label +
                                 "' cannot be read");
  };
  if (const auto* type = discriminator.enum_type()) {
    for (int i = 0; i < type->value_count(); ++i) {
      if (type->value(i)->options().GetExtension(urs::options::idl_enumerator) == label)
        return type->value(i)->number();
    }
    throw bad();
  }
  if (label == "TRUE") return 1;
  if (label == "FALSE") return 0;
  if (label.size() >= 3 && label.front() == '\'' && label.back() == '\'') {
    const std::string inner = label.substr(1, label.size() - 2);
    if (inner.size() == 1) return static_cast<unsigned char>(inner[0]);
    static const std::map<std::string, char> escapes{{"\\n", '\n'}, {"\\t", '\t'},  {"\\r", '\r'},
                                                     {"\\0", '\0'}, {"\\\\", '\\'}, {"\\'", '\''}};
    const auto it = escapes.find(inner);
    if (it != escapes.end()) return static_cast<unsigned char>(it->second);
    if (inner.size() > 2 && inner.compare(0, 2, "\\x") == 0) return std::stoi(inner.substr(2), nullptr, 16);
    throw bad();
  }
  try {
    std::size_t used = 0;
    const std::int64_t value = std::stoll(label, &used, 0);
    if (used == label.size()) return value;
  } catch (const std::exception&) {
  }
  throw bad();
}

std::string scoped_name(const std::string& repository_id) {
  if (repository_id.rfind("IDL:", 0) != 0) return repository_id;
  const auto colon = repository_id.rfind(':');
  std::string path = repository_id.substr(4, colon == std::string::npos || colon < 4 ? std::string::npos : colon - 4);
  // A #pragma prefix is a leading segment with dots in it, not a module.
  const auto slash = path.find('/');
  if (slash != std::string::npos && path.substr(0, slash).find('.') != std::string::npos) path.erase(0, slash + 1);
  std::string scoped;
  for (char c : path) {
    if (c == '/') {
      scoped += "::";
    } else {
      scoped += c;
    }
  }
  return scoped;
}

}  // namespace urs::corba_agent::detail
