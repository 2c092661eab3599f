#include "command_path.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

namespace plexus::app {

namespace {

namespace fs = std::filesystem;

bool executable_file(const fs::path& path) {
    std::error_code ec;
    return fs::is_regular_file(path, ec) && ::access(path.c_str(), X_OK) == 0;
}

/// The directories a command without a slash is looked for in, in order.
std::vector<fs::path> search_directories() {
    std::vector<fs::path> dirs;
    if (const char* path = std::getenv("PATH")) {
        std::string list = path;
        std::size_t start = 0;
        while (start <= list.size()) {
            const std::size_t end = std::min(list.find(':', start), list.size());
            // An empty PATH entry means the current directory, as for execvp.
            dirs.emplace_back(end == start ? "." : list.substr(start, end - start));
            start = end + 1;
        }
    }
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        dirs.push_back(self.parent_path());
        dirs.push_back(self.parent_path() / "sim");
        dirs.push_back(self.parent_path() / "bridge");  // plexus-bridge, in a build tree
    }
    return dirs;
}

}  // namespace

std::optional<std::string> find_command(const std::string& command, const std::string& app_directory) {
    if (command.find('/') != std::string::npos) {
        const fs::path path = (fs::path(app_directory) / command).lexically_normal();
        if (executable_file(path))
            return path.string();
        return std::nullopt;
    }
    for (const auto& dir : search_directories()) {
        const fs::path path = dir / command;
        if (executable_file(path)) {
            std::error_code ec;
            return fs::absolute(path, ec).lexically_normal().string();
        }
    }
    return std::nullopt;
}

std::string command_search_text(const std::string& command, const std::string& app_directory) {
    if (command.find('/') != std::string::npos)
        return "no executable file " + (fs::path(app_directory) / command).lexically_normal().string();
    std::string text = "no executable '" + command + "' in PATH";
    std::error_code ec;
    const fs::path self = fs::read_symlink("/proc/self/exe", ec);
    if (!ec)
        text += ", " + self.parent_path().string() + " or " + (self.parent_path() / "sim").string();
    return text;
}

}  // namespace plexus::app
