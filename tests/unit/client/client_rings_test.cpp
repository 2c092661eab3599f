// The client's end of the shared-memory rings (client_rings.hpp) against a daemon played by the
// test: the region and wake-ups made here, the daemon's end of the ring to it read here.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#include <future>
#include <vector>

#include "../../../client/src/client_rings.hpp"
#include "plexus/proto/rings.hpp"

namespace plexus::detail {
namespace {

using namespace std::chrono_literals;

/// The daemon's side of one client's rings: the region (mapped here too), the wake-up pipes it
/// writes and the socket's other end. Makes the client's ClientRings from the rest.
class FakeDaemon {
public:
    FakeDaemon() {
        layout_.ring_bytes = proto::RingLayout::min_ring_bytes;
        const int region = ::memfd_create("client-rings-test", MFD_CLOEXEC);
        EXPECT_GE(region, 0);
        EXPECT_EQ(::ftruncate(region, static_cast<off_t>(layout_.region_size())), 0);
        region_ = static_cast<std::uint8_t*>(
            ::mmap(nullptr, layout_.region_size(), PROT_READ | PROT_WRITE, MAP_SHARED, region, 0));
        EXPECT_NE(region_, MAP_FAILED);
        control_ = reinterpret_cast<proto::RingControl*>(region_ + proto::RingLayout::to_daemon_control);
        from_client_ = proto::RingReader(control_, region_ + layout_.to_daemon_data(), layout_.ring_bytes);
        int space[2];
        int data[2];
        EXPECT_EQ(::pipe2(space, O_CLOEXEC | O_NONBLOCK), 0);
        EXPECT_EQ(::pipe2(data, O_CLOEXEC | O_NONBLOCK), 0);
        signal_space_ = space[1];
        signal_data_ = data[1];
        int sockets[2];
        EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets), 0);
        socket_ = sockets[0];
        client_socket_ = sockets[1];
        std::vector<int> fds(proto::ring_descriptors);
        fds[proto::ring_region] = region;
        fds[proto::to_daemon_data] = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        fds[proto::to_daemon_space] = space[0];
        fds[proto::to_client_data] = data[0];
        fds[proto::to_client_space] = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        std::string why;
        rings_ = ClientRings::map(std::move(fds), layout_.ring_bytes, why);
        EXPECT_TRUE(rings_) << why;
    }
    ~FakeDaemon() {
        rings_.reset();
        ::munmap(region_, layout_.region_size());
        for (const int fd : {signal_space_, signal_data_, socket_, client_socket_})
            ::close(fd);
    }
    FakeDaemon(const FakeDaemon&) = delete;
    FakeDaemon& operator=(const FakeDaemon&) = delete;

    ClientRings& rings() { return *rings_; }
    int client_socket() const { return client_socket_; }
    bool writer_sleeps() const { return control_->writer_waiting.load() != 0; }

    /// Reads everything the client wrote, and signals room as the daemon does: only when the
    /// client said it sleeps. Returns the bytes read.
    std::size_t read_all() {
        std::vector<std::uint8_t> into(layout_.ring_bytes);
        bool wake = false;
        const auto n = from_client_.read_some(into.data(), into.size(), wake);
        if (wake) {
            const std::uint64_t one = 1;
            EXPECT_EQ(::write(signal_space_, &one, sizeof one), static_cast<ssize_t>(sizeof one));
        }
        return n.value_or(0);
    }

private:
    proto::RingLayout layout_;
    std::uint8_t* region_ = nullptr;
    proto::RingControl* control_ = nullptr;
    proto::RingReader from_client_;
    int signal_space_ = -1;
    int signal_data_ = -1;
    int socket_ = -1;
    int client_socket_ = -1;
    std::shared_ptr<ClientRings> rings_;
};

/// Fills the ring to the daemon.
void fill(ClientRings& rings) {
    std::vector<std::uint8_t> bytes(proto::RingLayout::min_ring_bytes);
    for (;;) {
        const iovec piece{bytes.data(), bytes.size()};
        const SocketSent sent = rings.send_some(&piece, 1);
        ASSERT_FALSE(sent.failure);
        if (sent.full)
            return;
    }
}

template <class Predicate>
bool eventually(Predicate predicate, std::chrono::milliseconds bound = 5s) {
    const auto deadline = std::chrono::steady_clock::now() + bound;
    while (!predicate()) {
        if (std::chrono::steady_clock::now() > deadline)
            return false;
        std::this_thread::yield();
    }
    return true;
}

TEST(ClientRings_test, AWriterWaitingForRoomWakesWhenTheDaemonReads) {
    FakeDaemon daemon;
    fill(daemon.rings());
    auto waiter = std::async(std::launch::async,
                             [&] { return daemon.rings().wait_writable(daemon.client_socket(), 10000); });
    ASSERT_TRUE(eventually([&] { return daemon.writer_sleeps(); }));
    EXPECT_GT(daemon.read_all(), 0u);
    ASSERT_EQ(waiter.wait_for(5s), std::future_status::ready) << "the writer was not woken";
    EXPECT_TRUE(waiter.get());
}

// A sender and the backlog thread may both wait for room at once (SendBuffer). The ring has one
// `writer_waiting` flag: a second sleeper that gave up cleared it under the first, the daemon then
// signalled no one, and the first slept its whole timeout with room to write. One sleeper at a time.
TEST(ClientRings_test, ASecondWaiterThatGivesUpDoesNotHideTheFirstFromTheDaemon) {
    FakeDaemon daemon;
    fill(daemon.rings());
    auto first = std::async(std::launch::async,
                            [&] { return daemon.rings().wait_writable(daemon.client_socket(), 10000); });
    ASSERT_TRUE(eventually([&] { return daemon.writer_sleeps(); }));
    auto second = std::async(std::launch::async,
                             [&] { return daemon.rings().wait_writable(daemon.client_socket(), 20); });
    // Without one sleeper at a time the second gives up after its 20 ms and clears the flag; with
    // it, it waits behind the first. Either way, the daemon reads after this.
    (void)second.wait_for(500ms);
    EXPECT_GT(daemon.read_all(), 0u);
    ASSERT_EQ(first.wait_for(5s), std::future_status::ready)
        << "the first waiter was not woken: the second cleared the flag the daemon looks at";
    EXPECT_TRUE(first.get());
    EXPECT_TRUE(second.get()) << "the second waiter found no room after the daemon read everything";
}

}  // namespace
}  // namespace plexus::detail
