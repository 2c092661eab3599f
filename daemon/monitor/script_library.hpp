#pragma once
// Finds monitor scripts by name in the daemon's --scripts directories (`file.NAME` -> NAME.lua),
// and compiled monitors in its --monitor-libs directories (`type.so+file.NAME` -> NAME.so), with
// the same name rules.

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

/// The absolute path of NAME.so (or NAME when it already ends in .so) in the first directory that
/// has it: the file is not read, dlopen loads it. Same name rules and errors as find_script.
proto::Result<Script> find_plugin(const std::string& name, const std::vector<std::string>& directories);

}  // namespace plexus::daemon::monitor
