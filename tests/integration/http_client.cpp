#include "http_client.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>

namespace plexus::test {

namespace {
using Clock = std::chrono::steady_clock;

int millis_left(Clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    return static_cast<int>(std::max<long long>(0, left));
}
}  // namespace

HttpConnection::HttpConnection(const std::string& address, int receive_buffer) {
    const auto colon = address.rfind(':');
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
    if (::inet_pton(AF_INET, address.substr(0, colon).c_str(), &to.sin_addr) != 1)
        return;
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ >= 0 && receive_buffer > 0)
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
    if (fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
        ::close(fd_);
        fd_ = -1;
    }
}

HttpConnection::~HttpConnection() {
    if (fd_ >= 0)
        ::close(fd_);
}

bool HttpConnection::send(const std::string& bytes) {
    std::size_t sent = 0;
    while (fd_ >= 0 && sent < bytes.size()) {
        const auto n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
        if (n <= 0)
            return false;
        sent += static_cast<std::size_t>(n);
    }
    return fd_ >= 0;
}

std::string HttpConnection::read_for(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    std::string got = std::move(pending_);
    pending_.clear();
    char buffer[16384];
    while (fd_ >= 0) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, millis_left(deadline)) <= 0)
            break;
        const auto n = ::recv(fd_, buffer, sizeof buffer, 0);
        if (n <= 0)
            break;
        got.append(buffer, static_cast<std::size_t>(n));
    }
    return got;
}

bool HttpConnection::closed_by_peer(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    char buffer[4096];
    while (fd_ >= 0) {
        pollfd p{fd_, POLLIN, 0};
        const int ready = ::poll(&p, 1, millis_left(deadline));
        if (ready <= 0)
            return false;
        const auto n = ::recv(fd_, buffer, sizeof buffer, 0);
        if (n <= 0)
            return true;
    }
    return true;
}

HttpReply HttpConnection::read_reply(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    std::string data = std::move(pending_);
    pending_.clear();
    HttpReply reply;
    char buffer[16384];
    auto read_more = [&] {
        pollfd p{fd_, POLLIN, 0};
        if (fd_ < 0 || ::poll(&p, 1, millis_left(deadline)) <= 0)
            return false;
        const auto n = ::recv(fd_, buffer, sizeof buffer, 0);
        if (n <= 0)
            return false;
        data.append(buffer, static_cast<std::size_t>(n));
        return true;
    };
    std::size_t header_end;
    while ((header_end = data.find("\r\n\r\n")) == std::string::npos) {
        if (!read_more())
            return reply;
    }
    const std::string head = data.substr(0, header_end);
    data.erase(0, header_end + 4);
    if (head.size() < 12 || head.compare(0, 5, "HTTP/") != 0)
        return reply;
    reply.status = std::stoi(head.substr(9, 3));
    std::size_t line = head.find("\r\n");
    while (line != std::string::npos) {
        const auto next = head.find("\r\n", line + 2);
        const auto text =
            head.substr(line + 2, next == std::string::npos ? std::string::npos : next - line - 2);
        const auto colon = text.find(':');
        if (colon != std::string::npos) {
            std::string name = text.substr(0, colon);
            std::transform(name.begin(), name.end(), name.begin(),
                           [](unsigned char c) { return std::tolower(c); });
            auto value = text.substr(colon + 1);
            value.erase(0, value.find_first_not_of(' '));
            reply.headers[name] = value;
        }
        line = next;
    }
    if (const auto length = reply.headers.find("content-length"); length != reply.headers.end()) {
        const auto size = std::stoul(length->second);
        while (data.size() < size && read_more()) {
        }
        reply.body = data.substr(0, size);
        pending_ = data.size() > size ? data.substr(size) : std::string();
    } else {
        while (read_more()) {
        }
        reply.body = data;
    }
    return reply;
}

HttpReply http_get(const std::string& address, const std::string& path, const std::string& extra) {
    HttpConnection connection(address);
    const std::string host = extra.find("Host:") == std::string::npos ? "Host: " + address + "\r\n" : "";
    if (!connection.send("GET " + path + " HTTP/1.1\r\n" + host + "Connection: close\r\n" + extra + "\r\n"))
        return {};
    return connection.read_reply();
}

}  // namespace plexus::test
