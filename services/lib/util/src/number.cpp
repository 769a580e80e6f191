#include "urs/util/number.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace urs::util {

std::optional<double> parse_number(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::string read_number(const std::string& text, double min, double max, double& out) {
  const auto value = parse_number(text);
  if (!value) return "'" + text + "' is not a number";
  if (*value < min || *value > max) {
    return "'" + text + "' is outside " + format_number(min) + " .. " + format_number(max);
  }
  out = *value;
  return {};
}

std::string format_number(double value) {
  // 15 significant digits print what people write (10, 0.1, 2.5); the few values that need
  // more to read back exactly get 17.
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", value);
  if (std::strtod(text, nullptr) != value) std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

}  // namespace urs::util
