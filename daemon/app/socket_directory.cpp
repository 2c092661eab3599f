#include "socket_directory.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <string>
#include <system_error>

#include "plexus/proto/errno_text.hpp"

namespace plexus::daemon {

namespace {
std::string octal(mode_t mode) {
    char text[8];
    std::snprintf(text, sizeof text, "%04o", static_cast<unsigned>(mode & 07777));
    return text;
}
}  // namespace

proto::Status prepare_socket_directory(const std::filesystem::path& directory) {
    const std::string shown = directory.string();
    if (directory.has_parent_path()) {
        std::error_code ignored;  // what matters is the check of the directory itself, below
        std::filesystem::create_directories(directory.parent_path(), ignored);
    }
    // Made here with 0700 at once (the umask can only take bits away), never made wider first.
    if (::mkdir(shown.c_str(), 0700) != 0 && errno != EEXIST)
        return proto::Error{proto::errno_text("cannot make the socket directory " + shown)};
    struct stat status {};
    if (::stat(shown.c_str(), &status) != 0)
        return proto::Error{proto::errno_text("cannot look at the socket directory " + shown)};
    if (!S_ISDIR(status.st_mode))
        return proto::Error{"the socket's directory " + shown + " is not a directory"};
    const uid_t mine = ::geteuid();
    if (status.st_uid != mine) {
        return proto::Error{"the socket directory " + shown + " belongs to uid " +
                            std::to_string(status.st_uid) + ", not to this daemon's user (uid " +
                            std::to_string(mine) +
                            "): its owner could replace the socket and every local client would talk to "
                            "them. Give --socket a path in a directory of your own"};
    }
    if ((status.st_mode & (S_IWGRP | S_IWOTH)) != 0) {
        return proto::Error{"the socket directory " + shown + " may be written by " +
                            ((status.st_mode & S_IWOTH) != 0 ? "every user" : "its group") + " (mode " +
                            octal(status.st_mode) +
                            "): they could replace the socket. Make it 0700 (or 0750 for a group "
                            "of clients: chmod go-w) or give --socket another directory"};
    }
    return proto::Ok{};
}

}  // namespace plexus::daemon
