#pragma once
// Finds monitor scripts by name in the daemon's --scripts directories: `file.NAME` -> NAME.lua.

#include <string>
#include <vector>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::monitor {

struct Script {
    std::string name;  ///< as the carrier gave it
    std::string path;  ///< the file it was read from
    std::string code;
};

/// Largest script file read; a monitor is a page of Lua, not a data file.
inline constexpr std::size_t max_script_bytes = 1024 * 1024;

/// Refuses names that could leave the directories (absolute, `..`, backslashes) or are empty.
proto::Status check_script_name(const std::string& name);

/// Reads NAME.lua (or NAME when it already ends in .lua) from the first directory that has it.
/// Errors say which directories were searched.
proto::Result<Script> find_script(const std::string& name, const std::vector<std::string>& directories);

}  // namespace plexus::daemon::monitor
