#pragma once
// The client side of the floor: a Unix-socket connection to a relay that writes and reads
// length-prefixed frames (floor_frame.hpp). Batches writes like libplexus does (up to 64 KiB per send).
//
// Threading: one thread per FloorSocket.

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace plexus::bench {

/// One frame as read; `payload` points into the socket's buffer and is valid until the next read.
struct FloorFrame {
    std::uint64_t seq = 0;
    std::uint64_t time_ns = 0;
    std::span<const std::uint8_t> payload;
};

class FloorSocket {
public:
    /// Connects to a relay's Unix socket; reads give up (throw) after `read_timeout`.
    FloorSocket(const std::string& path, std::chrono::milliseconds read_timeout);
    /// Takes over a connected stream socket (a TCP connection of `plexus-bench hosts`); `name`
    /// says which in error messages.
    FloorSocket(int connected_fd, std::string name, std::chrono::milliseconds read_timeout);
    ~FloorSocket();
    FloorSocket(const FloorSocket&) = delete;
    FloorSocket& operator=(const FloorSocket&) = delete;

    /// Queues a frame; sends when `flush` or when 64 KiB are waiting.
    void write(std::uint64_t seq, std::uint64_t time_ns, std::span<const std::uint8_t> payload, bool flush);
    void flush();
    /// The next frame; nullopt if none arrives within the read timeout; throws if the relay closed.
    std::optional<FloorFrame> read();
    /// How long read() waits before it gives up.
    void set_read_timeout(std::chrono::milliseconds timeout);

private:
    void send_all(std::span<const std::uint8_t> first, std::span<const std::uint8_t> second);

    int fd_ = -1;
    std::string path_;
    std::vector<std::uint8_t> out_;
    std::vector<std::uint8_t> in_;
    std::size_t in_begin_ = 0;
    std::size_t in_end_ = 0;
};

}  // namespace plexus::bench
