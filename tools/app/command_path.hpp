#pragma once
// Where a component's command is: a name without a slash is looked up in PATH, then beside the
// running `plexus` program and in its `sim/` subdirectory (so the programs built or installed
// with plexus are found without touching PATH); a command with a slash is relative to the
// application file's directory.

#include <optional>
#include <string>

namespace plexus::app {

/// The executable file `command` names, or none. `app_directory` anchors commands with a slash.
std::optional<std::string> find_command(const std::string& command, const std::string& app_directory);

/// What find_command looked through, for an error message.
std::string command_search_text(const std::string& command, const std::string& app_directory);

}  // namespace plexus::app
