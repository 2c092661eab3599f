#pragma once
// How a failed system call reads in an error: "mmap: Cannot allocate memory". Read errno right
// after the call, before anything else can change it.

#include <cerrno>
#include <cstring>
#include <string>
#include <string_view>

namespace plexus::proto {

inline std::string errno_text(std::string_view what) {
    return std::string(what) + ": " + std::strerror(errno);
}

}  // namespace plexus::proto
