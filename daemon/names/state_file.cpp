#include "state_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

namespace plexus::daemon::names {

namespace {

std::string system_error(const std::string& what, const std::string& path) {
    return what + " " + path + ": " + std::strerror(errno);
}

/// Closes a descriptor when it goes out of scope.
struct Descriptor {
    int fd;
    ~Descriptor() {
        if (fd >= 0)
            ::close(fd);
    }
};

proto::Status write_all(int fd, const std::string& text, const std::string& path) {
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return proto::Error{system_error("cannot write", path)};
        done += static_cast<std::size_t>(n);
    }
    return proto::Ok{};
}

}  // namespace

StateRead read_state(const std::string& path) {
    StateRead read;
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        return read;
    std::ifstream in(path, std::ios::binary);
    std::stringstream whole;
    whole << in.rdbuf();
    if (!in) {
        read.problems.push_back("state file " + path + " cannot be read: " + std::strerror(errno));
        return read;
    }
    const std::string text = whole.str();
    if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
        read.problems.push_back("state file " + path +
                                " is empty (a write that never reached the disk?): starting with no "
                                "persistent connections");
        return read;
    }
    nlohmann::json state;
    try {
        state = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        read.problems.push_back("state file " + path + " is not valid JSON (cut short?): " + e.what() +
                                "; starting with no persistent connections");
        return read;
    }
    if (!state.is_object() || !state.contains("persistent") || !state["persistent"].is_array()) {
        read.problems.push_back("state file " + path +
                                " has no \"persistent\" list: starting with no persistent connections");
        return read;
    }
    std::size_t index = 0;
    for (const auto& entry : state["persistent"]) {
        const bool whole_entry = entry.is_object() && entry.contains("source") &&
                                 entry["source"].is_string() && entry.contains("destination") &&
                                 entry["destination"].is_string() && entry.contains("carrier") &&
                                 entry["carrier"].is_string();
        if (whole_entry) {
            read.persistent.push_back({entry["source"].get<std::string>(),
                                       entry["destination"].get<std::string>(),
                                       entry["carrier"].get<std::string>(), true});
        } else {
            read.problems.push_back("state file " + path + ": persistent entry " + std::to_string(index) +
                                    " is not {source, destination, carrier}: skipped");
        }
        ++index;
    }
    return read;
}

std::string state_text(const std::vector<ConnectionEntry>& persistent) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& c : persistent)
        list.push_back({{"source", c.source}, {"destination", c.destination}, {"carrier", c.carrier}});
    return nlohmann::json{{"persistent", list}}.dump(2) + "\n";
}

proto::Status write_durably(const std::string& path, const std::string& text) {
    // rename() alone orders nothing on the disk: after a power cut the new name can point at a
    // file whose data never got there (an empty file). fsync the data before the rename, and the
    // directory after it, so that the rename itself is on the disk when this returns.
    const std::string temporary = path + ".tmp";
    {
        Descriptor file{::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)};
        if (file.fd < 0)
            return proto::Error{system_error("cannot create", temporary)};
        if (auto written = write_all(file.fd, text, temporary); !written)
            return written;
        if (::fsync(file.fd) != 0)
            return proto::Error{system_error("cannot fsync", temporary)};
    }
    if (::rename(temporary.c_str(), path.c_str()) != 0)
        return proto::Error{system_error("cannot rename " + temporary + " to", path)};
    std::filesystem::path directory = std::filesystem::path(path).parent_path();
    if (directory.empty())
        directory = ".";
    Descriptor dir{::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)};
    if (dir.fd < 0)
        return proto::Error{system_error("cannot open directory", directory.string())};
    if (::fsync(dir.fd) != 0)
        return proto::Error{system_error("cannot fsync directory", directory.string())};
    return proto::Ok{};
}

}  // namespace plexus::daemon::names
