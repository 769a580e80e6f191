#pragma once
// A compact JSON text built in place: what the gateway's protocol messages are written with.
// The caller writes a well-formed sequence (keys inside objects, values after keys); nothing is
// checked but string escaping (RFC 8259; bytes that are not UTF-8 are written as given).

#include <cstdint>
#include <string>
#include <string_view>

namespace urs::gateway {

class JsonWriter {
 public:
  JsonWriter& begin_object() { return open('{'); }
  JsonWriter& end_object() { return close('}'); }
  JsonWriter& begin_array() { return open('['); }
  JsonWriter& end_array() { return close(']'); }
  JsonWriter& key(std::string_view name);
  JsonWriter& value(std::string_view text);
  JsonWriter& value(const char* text) { return value(std::string_view(text)); }
  JsonWriter& value(const std::string& text) { return value(std::string_view(text)); }
  JsonWriter& value(double number);
  JsonWriter& value(int64_t number);
  JsonWriter& value(uint64_t number);
  JsonWriter& value(int number) { return value(static_cast<int64_t>(number)); }
  JsonWriter& value(unsigned number) { return value(static_cast<uint64_t>(number)); }
  JsonWriter& value(bool flag);
  JsonWriter& null();
  // A value that is JSON text already (e.g. a schema or a message from message_to_json()).
  JsonWriter& raw(std::string_view json);

  const std::string& str() const { return out_; }
  std::string take() { return std::move(out_); }

 private:
  JsonWriter& open(char c);
  JsonWriter& close(char c);
  void separate();

  std::string out_;
  bool first_ = true;  // no element written yet in the current object or array
  bool after_key_ = false;
};

}  // namespace urs::gateway
