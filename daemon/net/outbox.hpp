#pragma once
// Threading: one io_context thread; one Outbox per socket.

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <vector>

#include "../core/reader_queue.hpp"
#include "asio.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

/// A queue of messages that leaves on this socket as data frames tagged with `handle`.
struct OutSource {
    std::uint64_t handle = 0;
    ReaderQueue* queue = nullptr;
    std::uint64_t* sent_counter = nullptr;  ///< incremented per message written; may be null
    std::shared_ptr<void> keep_alive;       ///< owns what `queue` points into
};

/// One gathered write: buffers point into `control`, `flat` and the kept messages. Small records
/// are copied into `flat` with their frame headers, so a batch of thousands of small messages is a
/// handful of buffers (Asio sends at most 64 buffers per system call); large records are sent from
/// where they are.
struct Batch {
    std::vector<asio::const_buffer> buffers;
    std::vector<Message> messages;  ///< the large records referenced by `buffers`
    std::vector<proto::Bytes> control;
    proto::Bytes flat;
    std::size_t bytes = 0;
    std::size_t largest = 0;  ///< the largest record or batch of records in it
    void clear();
    bool empty() const { return buffers.empty(); }
};

/// Everything waiting to be written on one socket: control frames first, then data frames taken
/// round-robin from the sources, gathered so that many small frames leave in one system call.
class Outbox {
public:
    /// `on_space` runs when a strict queue drops below capacity (wakes writers held back).
    explicit Outbox(std::function<void()> on_space) : on_space_(std::move(on_space)) {}

    void push_control(proto::Bytes frame) {
        control_bytes_ += frame.size();
        control_.push_back(std::move(frame));
    }
    /// Bytes of control frames (replies, errors) not yet handed to the socket.
    std::size_t control_bytes() const { return control_bytes_; }
    void add_source(OutSource source) { sources_.push_back(std::move(source)); }
    void remove_source(std::uint64_t handle);
    bool empty() const;

    /// Moves frames worth about `budget` bytes (at least one frame) into `batch`.
    void fill(Batch& batch, std::size_t budget);

private:
    std::function<void()> on_space_;
    std::deque<proto::Bytes> control_;
    std::size_t control_bytes_ = 0;
    std::vector<OutSource> sources_;
    std::size_t next_source_ = 0;
};

}  // namespace plexus::daemon
