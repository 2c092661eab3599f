// Two ByteStreams over a socket pair, encrypted with the deployment secret: bytes written in pieces
// of every size arrive whole and in order, whatever the reader's buffer (a record larger than the
// reader's room is opened in place and handed on over several reads), both ways at once.

#include "net/byte_stream.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>

#include <boost/asio/co_spawn.hpp>
#include <boost/asio/detached.hpp>
#include <boost/asio/io_context.hpp>

#include "net/tls_context.hpp"
#include "plexus/proto/auth.hpp"

namespace plexus::daemon {
namespace byte_stream_test {
namespace {

proto::Bytes pattern(std::size_t size, std::uint8_t seed) {
    proto::Bytes bytes(size);
    for (std::size_t i = 0; i < size; ++i)
        bytes[i] = static_cast<std::uint8_t>(seed + i * 13 + i / 509);
    return bytes;
}

std::pair<Socket, Socket> socket_pair(asio::io_context& io) {
    int ends[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM, 0, ends) != 0)
        throw std::runtime_error("socketpair failed");
    const asio::generic::stream_protocol protocol(AF_UNIX, SOCK_STREAM);
    return {Socket(io, protocol, ends[0]), Socket(io, protocol, ends[1])};
}

/// Runs handlers until `done` says so, or nothing happens for 5 s.
template <class Done>
void run_until(asio::io_context& io, Done done) {
    while (!done() && io.run_one_for(std::chrono::seconds(5)) > 0) {
    }
}

/// Runs the TLS handshake of two streams under the deployment secret; an error's words, or "".
std::string handshake(asio::io_context& io, ByteStream& accepting, ByteStream& connecting) {
    auto secret = proto::Secret::from_bytes("a deployment secret long enough to be one");
    if (!secret)
        return secret.error().message;
    const auto context = TlsContext::of(*secret);
    proto::Status accepted = proto::Error{"not run"};
    proto::Status connected = proto::Error{"not run"};
    asio::co_spawn(
        io, [&]() -> Task<void> { accepted = co_await accepting.start_tls(*context, true); }, asio::detached);
    asio::co_spawn(
        io, [&]() -> Task<void> { connected = co_await connecting.start_tls(*context, false); },
        asio::detached);
    run_until(io, [&] { return accepted && connected; });
    if (!accepted)
        return "accepting: " + accepted.error().message;
    if (!connected)
        return "connecting: " + connected.error().message;
    return "";
}

/// Writes `pieces` in batches of three, as a connection's writer hands over its frames.
Task<void> write_all(ByteStream& stream, const std::vector<proto::Bytes>& pieces, bool& failed) {
    for (std::size_t at = 0; at < pieces.size(); at += 3) {
        std::vector<asio::const_buffer> batch;
        for (std::size_t i = at; i < std::min(at + 3, pieces.size()); ++i)
            batch.push_back(asio::buffer(pieces[i]));
        auto [error, n] = co_await stream.write(batch);
        failed = failed || error;
    }
}

/// Reads `size` bytes with buffers of the sizes in `rooms`, in turn.
Task<void> read_all(ByteStream& stream, std::size_t size, std::vector<std::size_t> rooms, proto::Bytes& into,
                    std::string& failure) {
    into.resize(size);
    std::size_t got = 0;
    for (std::size_t turn = 0; got < size; ++turn) {
        const std::size_t room = std::min(rooms[turn % rooms.size()], size - got);
        auto [error, n] = co_await stream.read_some(asio::buffer(into.data() + got, room));
        if (error) {
            failure = error.message() + " after " + std::to_string(got) + " bytes";
            co_return;
        }
        got += n;
    }
}

TEST(ByteStream_test, EncryptedBytesArriveWholeAndInOrderWhateverTheReadersRoomBothWaysAtOnce) {
    asio::io_context io;
    auto [left_socket, right_socket] = socket_pair(io);
    ByteStream left(std::move(left_socket));
    ByteStream right(std::move(right_socket));
    ASSERT_EQ(handshake(io, left, right), "");
    ASSERT_TRUE(left.encrypted() && right.encrypted());

    // Sizes around a record's 16 KiB and a write slice's 128 KiB, and many small ones.
    std::vector<proto::Bytes> pieces;
    std::size_t total = 0;
    std::uint8_t seed = 0;
    for (const std::size_t size : {1, 7, 300, 16 * 1024 - 1, 16 * 1024, 16 * 1024 + 1, 5, 128 * 1024,
                                   128 * 1024 + 3, 9, 700 * 1024, 64, 64, 64, 40'000}) {
        pieces.push_back(pattern(size, seed++));
        total += size;
    }
    proto::Bytes expected;
    for (const auto& piece : pieces)
        expected.insert(expected.end(), piece.begin(), piece.end());

    bool left_write_failed = false;
    bool right_write_failed = false;
    proto::Bytes at_right;
    proto::Bytes at_left;
    std::string right_failure;
    std::string left_failure;
    asio::co_spawn(io, write_all(left, pieces, left_write_failed), asio::detached);
    asio::co_spawn(io, write_all(right, pieces, right_write_failed), asio::detached);
    // Rooms smaller than a record (opened in place, handed on over several reads) and larger.
    asio::co_spawn(
        io, read_all(right, total, {7, 100, 5'000, 20'000, 300'000, 1, 16 * 1024}, at_right, right_failure),
        asio::detached);
    asio::co_spawn(io, read_all(left, total, {1'000'000, 3}, at_left, left_failure), asio::detached);
    io.restart();  // in case the handshake ran out of work
    io.run();

    EXPECT_FALSE(left_write_failed);
    EXPECT_FALSE(right_write_failed);
    EXPECT_EQ(right_failure, "");
    EXPECT_EQ(left_failure, "");
    EXPECT_TRUE(at_right == expected);
    EXPECT_TRUE(at_left == expected);
}

TEST(ByteStream_test, AByteFlippedOnTheWireEndsTheReadWithABadRecordMacThatTheNextReadRepeats) {
    asio::io_context io;
    // The writer's side is a plain socket in the middle: the test alters what passes.
    auto [left_socket, middle] = socket_pair(io);
    auto [middle_out, right_socket] = socket_pair(io);
    ByteStream left(std::move(left_socket));
    ByteStream right(std::move(right_socket));
    bool alter = false;
    auto relay = [&](Socket& from, Socket& to, bool toward_right) -> Task<void> {
        std::array<std::uint8_t, 4096> buffer;
        for (;;) {
            auto [error, n] = co_await from.async_read_some(asio::buffer(buffer), use_nothrow);
            if (error)
                co_return;
            if (toward_right && alter) {
                buffer[n - 1] ^= 0x40;  // the last byte of the record: its tag
                alter = false;
            }
            auto [write_error, written] =
                co_await asio::async_write(to, asio::buffer(buffer.data(), n), use_nothrow);
            if (write_error)
                co_return;
        }
    };
    asio::co_spawn(io, relay(middle, middle_out, true), asio::detached);
    asio::co_spawn(io, relay(middle_out, middle, false), asio::detached);
    ASSERT_EQ(handshake(io, right, left), "");

    alter = true;
    const proto::Bytes message = pattern(100, 1);
    boost::system::error_code first_error;
    boost::system::error_code second_error;
    std::size_t first_read = 0;
    asio::co_spawn(
        io,
        [&]() -> Task<void> {
            // One write, one record: the relay alters its tag.
            const std::vector<asio::const_buffer> one{asio::buffer(message)};
            co_await left.write(one);
        },
        asio::detached);
    asio::co_spawn(
        io,
        [&]() -> Task<void> {
            proto::Bytes into(1000);
            std::tie(first_error, first_read) = co_await right.read_some(asio::buffer(into));
            // The error is kept: a second read says it again.
            std::size_t second_read = 0;
            std::tie(second_error, second_read) = co_await right.read_some(asio::buffer(into));
        },
        asio::detached);
    run_until(io, [&] { return static_cast<bool>(second_error); });
    EXPECT_TRUE(ByteStream::is_tls_error(first_error)) << first_error.message();
    EXPECT_FALSE(ByteStream::is_peer_alert(first_error));
    EXPECT_EQ(first_read, 0u);
    EXPECT_EQ(second_error, first_error);
    EXPECT_NE(first_error.message().find("bad record mac"), std::string::npos) << first_error.message();
}

}  // namespace
}  // namespace byte_stream_test
}  // namespace plexus::daemon
