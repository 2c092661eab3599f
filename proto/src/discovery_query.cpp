// The discovery query on plain sockets (see discovery.hpp for why it lives in proto/).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>

#include "plexus/proto/discovery.hpp"

namespace plexus::proto {

namespace {
/// Closes the descriptor on every way out.
struct Descriptor {
    int fd;
    ~Descriptor() {
        if (fd >= 0)
            ::close(fd);
    }
};
}  // namespace

DiscoveryResult query_discovery(const Endpoint& group, std::chrono::milliseconds timeout, int ttl,
                                const Secret* secret) {
    DiscoveryResult result;
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(group.port);
    if (::inet_pton(AF_INET, group.host.c_str(), &to.sin_addr) != 1)
        return result;
    Descriptor socket{::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)};
    if (socket.fd < 0)
        return result;
    const unsigned char hops = static_cast<unsigned char>(ttl);
    ::setsockopt(socket.fd, IPPROTO_IP, IP_MULTICAST_TTL, &hops, sizeof hops);
    const unsigned char loop = 1;  // a name server on this very host answers too
    ::setsockopt(socket.fd, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop);
    const std::string nonce = discovery_nonce();
    const Bytes query = discovery_query(nonce);
    constexpr int tries = 3;
    const auto per_try = timeout / tries;
    std::array<std::uint8_t, 2048> buffer{};
    for (int attempt = 0; attempt < tries; ++attempt) {
        if (::sendto(socket.fd, query.data(), query.size(), 0, reinterpret_cast<const sockaddr*>(&to),
                     sizeof to) < 0) {
            return result;  // no route for multicast: nobody to ask
        }
        const auto deadline = std::chrono::steady_clock::now() + per_try;
        for (;;) {
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                deadline - std::chrono::steady_clock::now());
            if (left.count() <= 0)
                break;
            pollfd ready{socket.fd, POLLIN, 0};
            if (::poll(&ready, 1, static_cast<int>(left.count())) <= 0)
                break;
            sockaddr_in from{};
            socklen_t from_size = sizeof from;
            const auto n = ::recvfrom(socket.fd, buffer.data(), buffer.size(), 0,
                                      reinterpret_cast<sockaddr*>(&from), &from_size);
            if (n <= 0)
                continue;
            std::array<char, INET_ADDRSTRLEN> text{};
            ::inet_ntop(AF_INET, &from.sin_addr, text.data(), text.size());
            auto answer =
                discovery_answer({buffer.data(), static_cast<std::size_t>(n)}, text.data(), secret, nonce);
            if (!answer)
                continue;
            if (secret && !answer->proven) {
                // Not one of this deployment's name servers (or a forgery): wait on for one that is.
                if (std::find(result.ignored.begin(), result.ignored.end(), text.data()) ==
                    result.ignored.end())
                    result.ignored.emplace_back(text.data());
                continue;
            }
            result.names = answer->names;
            return result;
        }
    }
    return result;
}

Result<NamesChoice> find_names(const std::optional<std::string>& flag, const std::string& config_file,
                               std::chrono::milliseconds timeout, const Secret* secret) {
    std::vector<std::string> ignored;
    auto choice = choose_names(flag, config_file, [&]() -> std::optional<std::string> {
        auto group = discovery_group();
        if (!group || !*group)
            return std::nullopt;
        auto found = query_discovery(**group, timeout, default_discovery_ttl, secret);
        ignored = std::move(found.ignored);
        return found.names;
    });
    if (choice && !ignored.empty()) {
        std::string from;
        for (const auto& address : ignored)
            from += (from.empty() ? "" : ", ") + address;
        choice->detail += "; ignored answers without this deployment's proof from " + from;
    }
    return choice;
}

}  // namespace plexus::proto
