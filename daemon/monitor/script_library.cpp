#include "script_library.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace plexus::daemon::monitor {

proto::Status check_script_name(const std::string& name) {
    if (name.empty())
        return proto::Error{"empty script name (file.NAME)"};
    if (name.front() == '/' || name.find('\\') != std::string::npos || name.find('\0') != std::string::npos)
        return proto::Error{"script name '" + name + "' must be relative to a --scripts directory"};
    for (const auto& part : std::filesystem::path(name)) {
        if (part == "..")
            return proto::Error{"script name '" + name + "' must not contain '..'"};
    }
    return proto::Ok{};
}

proto::Result<Script> find_script(const std::string& name, const std::vector<std::string>& directories) {
    if (auto valid = check_script_name(name); !valid)
        return valid.error();
    const bool has_extension = name.size() > 4 && name.compare(name.size() - 4, 4, ".lua") == 0;
    const std::string file = has_extension ? name : name + ".lua";
    std::string searched;
    for (const auto& directory : directories) {
        const std::filesystem::path path = std::filesystem::path(directory) / file;
        std::error_code ec;
        if (!std::filesystem::is_regular_file(path, ec)) {
            searched += (searched.empty() ? "" : ", ") + directory;
            continue;
        }
        const auto size = std::filesystem::file_size(path, ec);
        if (ec || size > max_script_bytes)
            return proto::Error{"script " + path.string() + " is larger than " +
                                std::to_string(max_script_bytes) + " bytes or unreadable"};
        std::ifstream in(path, std::ios::binary);
        std::ostringstream code;
        code << in.rdbuf();
        if (!in)
            return proto::Error{"cannot read script " + path.string()};
        return Script{name, path.string(), code.str()};
    }
    if (directories.empty())
        return proto::Error{"script '" + name + "' not found: the daemon has no --scripts directory"};
    return proto::Error{"script '" + file + "' not found in " + searched};
}

proto::Result<Script> find_plugin(const std::string& name, const std::vector<std::string>& directories) {
    if (auto valid = check_script_name(name); !valid)
        return valid.error();
    const bool has_extension = name.size() > 3 && name.compare(name.size() - 3, 3, ".so") == 0;
    const std::string file = has_extension ? name : name + ".so";
    std::string searched;
    for (const auto& directory : directories) {
        std::error_code ec;
        // Absolute, so that dlopen takes it as a file and never searches the library path.
        const auto path = std::filesystem::absolute(std::filesystem::path(directory) / file, ec);
        if (ec || !std::filesystem::is_regular_file(path, ec)) {
            searched += (searched.empty() ? "" : ", ") + directory;
            continue;
        }
        return Script{name, path.string(), {}};
    }
    if (directories.empty())
        return proto::Error{"monitor plugin '" + name +
                            "' not found: the daemon has no --monitor-libs directory (plugins are loaded "
                            "only from there)"};
    return proto::Error{"monitor plugin '" + file + "' not found in the --monitor-libs directories " +
                        searched};
}

}  // namespace plexus::daemon::monitor
