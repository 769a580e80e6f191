#pragma once
// JSON text for programs that print what they read as JSON lines by hand (the urs CLI's payloads
// and events, tools reading DDS samples): no JSON library, no allocation beyond the result.

#include <string>
#include <string_view>

namespace urs::util {

// `text` as a JSON string literal, quotes included (RFC 8259 escaping: `"`, `\` and control
// characters; other bytes, UTF-8 included, as they are).
std::string json_string(std::string_view text);

// `bytes` in standard base64 with padding (RFC 4648), as JSON carries bytes.
std::string base64(std::string_view bytes);

}  // namespace urs::util
