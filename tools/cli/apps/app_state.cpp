#include "app_state.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "plexus/client.hpp"

namespace plexus::cli {

namespace fs = std::filesystem;

std::string apps_directory(const std::string& socket) {
    return (fs::absolute(socket).parent_path() / "apps").string();
}

std::string state_path(const std::string& socket, const std::string& app_name) {
    return apps_directory(socket) + "/" + app_name + ".json";
}

std::string log_path(const std::string& socket, const std::string& app_name, const std::string& component) {
    return apps_directory(socket) + "/" + app_name + "/" + component + ".log";
}

AppState read_state(const std::string& path) {
    AppState state;
    std::ifstream in(path);
    if (!in)
        return state;
    std::stringstream text;
    text << in.rdbuf();
    try {
        const auto json = Value::parse(text.str());
        state.file = json.value("file", "");
        for (const auto& [name, c] : json.at("components").items()) {
            ComponentRecord record;
            record.pid = c.at("pid").get<pid_t>();
            record.start_time = c.at("start_time").get<unsigned long long>();
            record.log = c.value("log", "");
            record.node = c.value("node", "");
            record.socket = c.value("socket", "");
            record.started_at = c.value("started_at", "");
            state.components[name] = record;
        }
    } catch (const std::exception& e) {
        throw Error(ErrorCode::usage, "the state file " + path + " is damaged (" + e.what() +
                                          "); stop its components by hand and remove it");
    }
    return state;
}

void write_state(const std::string& path, const AppState& state) {
    std::error_code ec;
    if (state.components.empty()) {
        fs::remove(path, ec);
        return;
    }
    Value json = {{"file", state.file}, {"components", Value::object()}};
    for (const auto& [name, r] : state.components) {
        json["components"][name] = {{"pid", r.pid},       {"start_time", r.start_time},
                                    {"log", r.log},       {"node", r.node},
                                    {"socket", r.socket}, {"started_at", r.started_at}};
    }
    fs::create_directories(fs::path(path).parent_path(), ec);
    const std::string temporary = path + ".tmp." + std::to_string(::getpid());
    const std::string text = json.dump(2) + "\n";
    // Written, synced, then renamed: a reader (or a crash) sees the old state or the new, never half.
    const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (fd < 0)
        throw Error(ErrorCode::refused, "cannot write " + temporary + ": " + std::strerror(errno));
    const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
    const bool synced = ::fsync(fd) == 0;
    ::close(fd);
    if (!written || !synced || std::rename(temporary.c_str(), path.c_str()) != 0) {
        fs::remove(temporary, ec);
        throw Error(ErrorCode::refused, "cannot write " + path + ": " + std::strerror(errno));
    }
}

}  // namespace plexus::cli
