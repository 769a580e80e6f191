#pragma once
// `urs rtc conf ...`: a component's configuration sets (SDOPackage::Configuration), as rtshell's
// rtconf reads and changes them, so OpenRTM-aist components and URSLink's answer alike. Each
// returns the exit code and prints as docs/rtc.md says; failures are thrown as Failure.

#include <string>

#include "rtc_session.hpp"

namespace urs::cli::rtc_cli {

// Every set, the active one marked "(active)", each followed by its parameters "  name=value".
int conf_list(Session& session, const std::string& path);
// The value of `name` in `set` (default: the active set).
int conf_get(Session& session, const std::string& path, const std::string& name, const std::string& set);
// Sets `name` to `value` in `set` (default: the active set), re-activates the set if it is the
// active one (as rtconf does: OpenRTM-aist components apply values on activation) and reads the
// value back: a set showing another value fails the command, naming the value asked and the one
// kept. A component whose set holds the text while it uses another value (an unmodified
// OpenRTM-aist component whose variable cannot parse the text) is not caught: docs/rtc.md.
int conf_set(Session& session, const std::string& path, const std::string& name, const std::string& value,
             const std::string& set);
// Makes `set` the active configuration set.
int conf_activate(Session& session, const std::string& path, const std::string& set);

}  // namespace urs::cli::rtc_cli
