#pragma once
// The flags every URSLink program of a space takes: --space and --config (both required),
// --log-level and --log-format. Header-only (CLI11 is header-only too; the App type is a template parameter so that
// this library does not depend on it).

#include <string>

#include "urs/util/cli.hpp"
#include "urs/util/log_format.hpp"

namespace urs::util {

// Adds --log-format (text or json lines: urs/util/log_format.hpp) to `app`, into `format`.
template <typename App>
void add_log_format_flag(App& app, std::string& format) {
  app.add_option("--log-format", format,
                 std::string("Log lines as text or as one JSON object each (") + kLogFormats + ")")
      ->capture_default_str();
}

struct ProgramFlags {
  std::string space;                // --space: the name of the space the program belongs to
  std::string config_path;          // --config: its YAML configuration file
  std::string log_level = "info";   // --log-level: one of kLogLevels
  std::string log_format = "text";  // --log-format: one of kLogFormats

  // How `program` logs with these flags.
  LogOptions log_options(const std::string& program) const { return {program, log_level, log_format, space}; }
};

// Adds --space (help `space_help`), --config (help `config_help`), --log-level and --log-format
// to `app`.
template <typename App>
void add_program_flags(App& app, ProgramFlags& flags, const std::string& space_help, const std::string& config_help) {
  app.add_option("--space", flags.space, space_help)->required();
  app.add_option("--config", flags.config_path, config_help)->required();
  app.add_option("--log-level", flags.log_level, kLogLevels)->capture_default_str();
  add_log_format_flag(app, flags.log_format);
}

}  // namespace urs::util
