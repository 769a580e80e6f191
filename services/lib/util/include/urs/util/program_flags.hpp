#pragma once
// The flags every URSLink program of a space takes: --space and --config (both required) and
// --log-level. Header-only (CLI11 is header-only too; the App type is a template parameter so that
// this library does not depend on it).

#include <string>

#include "urs/util/cli.hpp"

namespace urs::util {

struct ProgramFlags {
  std::string space;             // --space: the name of the space the program belongs to
  std::string config_path;       // --config: its YAML configuration file
  std::string log_level = "info";  // --log-level: one of kLogLevels
};

// Adds --space (help `space_help`), --config (help `config_help`) and --log-level to `app`.
template <typename App>
void add_program_flags(App& app, ProgramFlags& flags, const std::string& space_help, const std::string& config_help) {
  app.add_option("--space", flags.space, space_help)->required();
  app.add_option("--config", flags.config_path, config_help)->required();
  app.add_option("--log-level", flags.log_level, kLogLevels)->capture_default_str();
}

}  // namespace urs::util
