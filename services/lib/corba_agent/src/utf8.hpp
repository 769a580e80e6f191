#pragma once
// UTF-8 (Protobuf strings) <-> Unicode code points (IDL char, wchar and wstring values).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace urs::corba_agent::detail {

// nullopt if `text` is not well-formed UTF-8 (overlong forms and surrogates included).
inline std::optional<std::vector<std::uint32_t>> utf8_to_code_points(const std::string& text) {
  std::vector<std::uint32_t> points;
  points.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const auto lead = static_cast<unsigned char>(text[i]);
    int extra = 0;
    std::uint32_t point = 0;
    std::uint32_t minimum = 0;
    if (lead < 0x80) {
      point = lead;
    } else if ((lead & 0xE0) == 0xC0) {
      extra = 1, point = lead & 0x1F, minimum = 0x80;
    } else if ((lead & 0xF0) == 0xE0) {
      extra = 2, point = lead & 0x0F, minimum = 0x800;
    } else if ((lead & 0xF8) == 0xF0) {
      extra = 3, point = lead & 0x07, minimum = 0x10000;
    } else {
      return std::nullopt;
    }
    if (i + extra >= text.size()) return std::nullopt;  // truncated sequence
    for (int k = 1; k <= extra; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      if ((next & 0xC0) != 0x80) return std::nullopt;
      point = (point << 6) | (next & 0x3F);
    }
    if (point < minimum || point > 0x10FFFF || (point >= 0xD800 && point <= 0xDFFF)) return std::nullopt;
    points.push_back(point);
    i += 1 + extra;
  }
  return points;
}

inline std::string code_points_to_utf8(const std::vector<std::uint32_t>& points) {
  std::string text;
  for (std::uint32_t p : points) {
    if (p < 0x80) {
      text += static_cast<char>(p);
    } else if (p < 0x800) {
      text += static_cast<char>(0xC0 | (p >> 6));
      text += static_cast<char>(0x80 | (p & 0x3F));
    } else if (p < 0x10000) {
      text += static_cast<char>(0xE0 | (p >> 12));
      text += static_cast<char>(0x80 | ((p >> 6) & 0x3F));
      text += static_cast<char>(0x80 | (p & 0x3F));
    } else {
      text += static_cast<char>(0xF0 | (p >> 18));
      text += static_cast<char>(0x80 | ((p >> 12) & 0x3F));
      text += static_cast<char>(0x80 | ((p >> 6) & 0x3F));
      text += static_cast<char>(0x80 | (p & 0x3F));
    }
  }
  return text;
}

}  // namespace urs::corba_agent::detail
