// A Connection (connection.hpp) against a peer played by the test over a socketpair: its receiving
// thread delivers replies and records, a peer that goes away wakes the reader with an error, the
// destructor ends the receiving thread while it waits in a read, and a writer blocked on a full
// socket does not stop the reads the peer waits for (the deadlock a dedicated receiver removes).
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <future>
#include <thread>

#include "../../../client/src/connection.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::detail {
namespace {

using namespace std::chrono_literals;

/// The test's end of the socketpair: whole frames in, bytes out, blocking.
class Peer {
public:
    explicit Peer(int fd) : fd_(fd) {}
    ~Peer() { close(); }
    void close() {
        if (fd_ >= 0)
            ::close(fd_);
        fd_ = -1;
    }
    void send(const proto::Bytes& bytes) {
        std::size_t sent = 0;
        while (sent < bytes.size()) {
            const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
            ASSERT_GT(n, 0) << "the peer's send failed";
            sent += static_cast<std::size_t>(n);
        }
    }
    /// The next whole frame: its type and fields.
    std::pair<proto::FrameType, proto::Bytes> receive_frame() {
        const proto::FrameDecoder decoder;
        for (;;) {
            const auto decoded = decoder.decode(in_);
            if (decoded.status == proto::DecodeStatus::frame) {
                std::pair<proto::FrameType, proto::Bytes> frame{
                    decoded.type, proto::Bytes(decoded.fields.begin(), decoded.fields.end())};
                in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(decoded.used));
                return frame;
            }
            std::uint8_t chunk[65536];
            const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
            if (n <= 0)
                throw std::runtime_error("the connection closed before a whole frame came");
            in_.insert(in_.end(), chunk, chunk + n);
        }
    }

private:
    int fd_;
    proto::Bytes in_;
};

struct Pair {
    Pair() {
        int fds[2];
        if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0)
            throw std::runtime_error("socketpair");
        connection = std::make_shared<Connection>(fds[0], "test", true);
        peer = std::make_unique<Peer>(fds[1]);
    }
    std::shared_ptr<Connection> connection;
    std::unique_ptr<Peer> peer;
};

proto::Bytes data_frame(std::uint64_t handle, std::uint64_t seq, std::size_t payload_size) {
    proto::Bytes record;
    proto::append_record(record, "/peer", seq, 0, proto::Bytes(payload_size, 0x42));
    proto::Bytes frame;
    proto::append_data_frame(frame, handle, record);
    return frame;
}

TEST(Connection_test, ARequestGetsItsReplyThroughTheReceivingThread) {
    Pair pair;
    auto daemon = std::async(std::launch::async, [&] {
        const auto [type, fields] = pair.peer->receive_frame();
        EXPECT_EQ(type, proto::FrameType::request);
        const auto request = proto::decode_request(fields);
        pair.peer->send(proto::encode_reply({request->id, proto::ReplyCode::ok, {{"answer", 42}}}));
    });
    const auto reply = pair.connection->request({{"op", "node"}}, 10s);
    EXPECT_EQ(reply.body["answer"], 42);
    daemon.get();
}

TEST(Connection_test, RecordsReachTheReaderOfTheirHandle) {
    Pair pair;
    proto::Bytes frames = data_frame(1, 1, 10);
    const auto second = data_frame(2, 1, 10);
    frames.insert(frames.end(), second.begin(), second.end());
    pair.peer->send(frames);
    std::deque<InboxSegment> one;
    ASSERT_TRUE(pair.connection->read_all(1, 10s, one));
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0].records.size(), 1u);
    std::deque<InboxSegment> two;
    EXPECT_TRUE(pair.connection->read_all(2, 10s, two));
}

TEST(Connection_test, APeerThatGoesAwayWakesTheReaderWithAnError) {
    Pair pair;
    auto reader = std::async(std::launch::async, [&] {
        std::deque<InboxSegment> into;
        return pair.connection->read_all(1, 10s, into);
    });
    pair.peer->close();
    EXPECT_THROW(reader.get(), Error);
    EXPECT_TRUE(pair.connection->broken());
}

TEST(Connection_test, TheDestructorEndsTheReceivingThreadBlockedInARead) {
    Pair pair;
    std::deque<InboxSegment> into;
    EXPECT_FALSE(pair.connection->read_all(1, 0ms, into));
    const auto start = Clock::now();
    pair.connection.reset();  // the receiving thread waits in recvmsg for a peer that sends nothing
    EXPECT_LT(Clock::now() - start, 5s);
}

TEST(Connection_test, AWriterBlockedOnAFullSocketDoesNotStopReceiving) {
    // The peer first sends far more than the socket holds and reads nothing until all of it is
    // taken, as a daemon does when a queue this client reads is full; this client meanwhile writes
    // more than the socket holds too. Both are blocked until one side reads: here the receiving
    // thread, while the writer waits for room.
    Pair pair;
    constexpr std::size_t frames = 64;
    constexpr std::size_t frame_payload = 128 * 1024;
    auto daemon = std::async(std::launch::async, [&] {
        for (std::size_t i = 0; i < frames; ++i)
            pair.peer->send(data_frame(1, i, frame_payload));
        const auto [type, fields] = pair.peer->receive_frame();
        return type;
    });
    const proto::Bytes large(8 * 1024 * 1024, 0x17);
    pair.connection->write(9, "/client", 1, large, {}, true);  // returns once the peer took it all
    EXPECT_EQ(daemon.get(), proto::FrameType::data);
    std::size_t records = 0;
    while (records < frames) {
        std::deque<InboxSegment> into;
        ASSERT_TRUE(pair.connection->read_all(1, 10s, into));
        for (const auto& segment : into)
            records += segment.whole ? 1 : segment.records.size();
    }
    EXPECT_EQ(records, frames);
}

}  // namespace
}  // namespace plexus::detail
