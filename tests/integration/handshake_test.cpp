// A peer that connects and never completes its handshake is cut off, on the daemon's and on the
// name server's TCP listeners, and counted: otherwise each such peer holds a socket and a session
// for good, and enough of them exhaust the daemon's descriptors.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <stdexcept>
#include <string>

#include "harness.hpp"
#include "plexus/proto/hello.hpp"

namespace plexus::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

/// A TCP connection to HOST:PORT that the test writes raw bytes to and watches for the peer's close.
class RawTcp {
public:
    explicit RawTcp(const std::string& host_port) {
        const auto colon = host_port.rfind(':');
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_port = htons(static_cast<std::uint16_t>(std::stoi(host_port.substr(colon + 1))));
        if (::inet_pton(AF_INET, host_port.substr(0, colon).c_str(), &address.sin_addr) != 1)
            throw std::runtime_error("not an IPv4 address: " + host_port);
        fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
        if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
            throw std::runtime_error("cannot connect to " + host_port);
    }
    ~RawTcp() { ::close(fd_); }
    RawTcp(const RawTcp&) = delete;
    RawTcp& operator=(const RawTcp&) = delete;

    void send(const proto::Bytes& bytes) {
        ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
    }

    /// True once the peer closed (EOF or reset) before `deadline`; what it sent first is read and
    /// dropped (its own hello).
    bool closed_by_peer(Clock::time_point deadline) {
        char buffer[4096];
        while (Clock::now() < deadline) {
            pollfd entry{fd_, POLLIN, 0};
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
            if (::poll(&entry, 1, static_cast<int>(std::max<long>(left, 0))) <= 0)
                continue;
            const auto got = ::recv(fd_, buffer, sizeof buffer, 0);
            if (got <= 0)
                return true;
        }
        return false;
    }

private:
    int fd_ = -1;
};

/// A config file that sets the daemon's handshake timeout.
std::vector<std::string> with_handshake_timeout(const TempDir& dir, int milliseconds) {
    const std::string config = dir.file("handshake.json");
    std::ofstream(config) << R"({"handshake_timeout_ms": )" << milliseconds << "}";
    return {"--config", config};
}

TEST(Handshake_test, ADaemonCutsOffAPeerThatSaysNothingOrOnlyPartOfItsHello) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", with_handshake_timeout(dir, 300));
    RawTcp silent(daemon.address());
    RawTcp partial(daemon.address());
    const auto hello = proto::encode_hello({proto::protocol_version, "client", "slow"});
    partial.send(proto::Bytes(hello.begin(), hello.begin() + 3));  // a frame that never completes
    const auto connected = Clock::now();
    EXPECT_TRUE(silent.closed_by_peer(connected + slower(10s))) << "a silent peer was never cut off";
    EXPECT_TRUE(partial.closed_by_peer(connected + slower(10s)))
        << "a peer with half a hello was never cut off";
    // Not before its time: 300 ms from connecting.
    EXPECT_GE(Clock::now() - connected, 300ms);
    json stats;
    ASSERT_TRUE(eventually([&] {
        stats = json::parse(run_cli(dir, daemon, {"stats", "--json"}).out);
        return stats["daemon"]["handshake_timeouts"] == 2;
    })) << stats.dump();
    // A peer that does say hello in time is served as ever.
    EXPECT_EQ(run_cli(dir, daemon, {"list"}).status, 0);
    const auto log = daemon.process().err() + daemon.process().out();
    EXPECT_NE(log.find("no hello within 300 ms of connecting: cut off"), std::string::npos) << log;
}

TEST(Handshake_test, TheNameServerCutsOffAPeerThatSaysNothing) {
    TempDir dir;
    NameServerProcess names(dir, {"--handshake-timeout-ms", "300"});
    RawTcp silent(names.address());
    EXPECT_TRUE(silent.closed_by_peer(Clock::now() + slower(10s))) << "a silent peer was never cut off";
    // A daemon registering through it is served as ever.
    Daemon daemon(dir, "solo", names.address());
    EXPECT_EQ(run_cli(dir, daemon, {"list"}).status, 0);
    const auto log = names.process().err() + names.process().out();
    EXPECT_NE(log.find("no hello within 300 ms of connecting: cut off"), std::string::npos) << log;
}

}  // namespace
}  // namespace plexus::test
