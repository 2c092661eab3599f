#include "server_process.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>

namespace plexus::bench::peers {

using namespace std::chrono_literals;

namespace {

sockaddr_in loopback(int port) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    return address;
}

}  // namespace

int free_tcp_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0)
        throw std::runtime_error("socket() failed");
    sockaddr_in address = loopback(0);
    socklen_t length = sizeof address;
    const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
                    ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
    ::close(fd);
    if (!ok)
        throw std::runtime_error("cannot find a free port on 127.0.0.1");
    return ntohs(address.sin_port);
}

bool accepts_connections(int port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0)
        return false;
    const sockaddr_in address = loopback(port);
    const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    ::close(fd);
    return ok;
}

std::unique_ptr<ChildProcess> start_server(const std::function<std::vector<std::string>(int port)>& make_argv,
                                           const std::string& log, int& port) {
    std::string why;
    for (int attempt = 0; attempt < 3; ++attempt) {
        port = free_tcp_port();
        const auto argv = make_argv(port);
        auto process = std::make_unique<ChildProcess>(argv, log);
        const bool listening =
            poll_until([&] { return !process->running() || accepts_connections(port); }, 10s) &&
            process->running();
        if (listening)
            return process;
        why = process->log_tail();
    }
    throw std::runtime_error(make_argv(port).front() + " did not start listening:\n" + why);
}

std::string find_program(const std::string& name) {
    std::vector<std::string> directories;
    if (const char* path = std::getenv("PATH")) {
        std::string all = path;
        for (std::size_t start = 0; start <= all.size();) {
            const auto end = std::min(all.find(':', start), all.size());
            directories.push_back(all.substr(start, end - start));
            start = end + 1;
        }
    }
    directories.insert(directories.end(), {"/usr/sbin", "/usr/bin", "/usr/local/sbin", "/usr/local/bin"});
    for (const auto& directory : directories) {
        if (directory.empty())
            continue;
        const std::filesystem::path candidate = std::filesystem::path(directory) / name;
        if (::access(candidate.c_str(), X_OK) == 0)
            return candidate.string();
    }
    return {};
}

}  // namespace plexus::bench::peers
