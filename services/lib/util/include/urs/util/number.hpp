#pragma once
// Numbers written as text by people and tools (configuration values, parameters).

#include <optional>
#include <string>

namespace urs::util {

// `text` as a finite decimal number, all of it ("2.5", "-1e3"); nullopt otherwise (" 2", "2x",
// "nan", "").
std::optional<double> parse_number(const std::string& text);
// Reads `text` as parse_number() does, within [min, max], into `out`: "" on success, else why not
// ("'fast' is not a number", "'3000' is outside 0 .. 1200"); `out` is unchanged then.
std::string read_number(const std::string& text, double min, double max, double& out);
// The shortest decimal text that reads back as `value`: 1, 2.5, 0.1.
std::string format_number(double value);

}  // namespace urs::util
