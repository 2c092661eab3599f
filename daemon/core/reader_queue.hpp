#pragma once
// Threading: its port's thread (see port.hpp); no locking.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <optional>
#include <string>

#include "message.hpp"

namespace plexus::daemon {

enum class QueuePolicy { strict, latest };

std::optional<QueuePolicy> parse_queue_policy(std::string_view text);
std::string_view queue_policy_name(QueuePolicy policy);

/// The bounded queue between a port and the client that reads it.
/// strict: never drops; `full()` tells writers to wait (back-pressure).
/// latest: keeps the `capacity` newest messages and counts every one it drops.
class ReaderQueue {
public:
    /// Default bound on the bytes a queue holds, whatever its length: a queue of 1,024 large images
    /// must not hold a GiB. 8 MiB, not more: with the sockets' buffers on both sides that keeps a
    /// stream of 1 MiB messages flowing, and a deeper queue only made the daemon slower (at 64 MiB
    /// a full queue of 1 MiB chunks kept the spare-chunk pool empty, so every frame was read into
    /// freshly faulted pages: 717 against 325-475 us of daemon CPU per message, 72 against 16 MB).
    static constexpr std::size_t default_max_bytes = 8u * 1024u * 1024u;

    ReaderQueue(QueuePolicy policy, std::size_t capacity, std::size_t max_bytes = default_max_bytes)
        : policy_(policy), capacity_(capacity), max_bytes_(max_bytes) {}

    /// True when a strict queue is at capacity (messages or bytes); a latest queue is never full.
    bool full() const {
        return policy_ == QueuePolicy::strict && (messages_ >= capacity_ || bytes_ >= max_bytes_);
    }
    /// Messages a strict queue takes before it is full (0 when full); a latest queue always has room.
    std::size_t room() const {
        if (policy_ == QueuePolicy::latest)
            return std::numeric_limits<std::size_t>::max();
        return full() ? 0 : capacity_ - messages_;
    }
    bool empty() const { return items_.empty(); }
    /// Messages queued (a batch counts as its records).
    std::size_t depth() const { return messages_; }
    std::size_t capacity() const { return capacity_; }
    std::size_t bytes() const { return bytes_; }
    QueuePolicy policy() const { return policy_; }

    /// Adds a message. A strict queue past capacity still accepts (nothing promised is lost): the
    /// bound is kept by writers that check full() before sending. A strict queue keeps a batch as
    /// one unit; a latest queue splits it.
    void push(const Message& message);
    /// Removes and returns the oldest message or batch; the queue must not be empty.
    Message pop();

    std::uint64_t pushed() const { return pushed_; }
    std::uint64_t dropped() const { return dropped_; }

private:
    QueuePolicy policy_;
    std::size_t capacity_;
    std::size_t max_bytes_;
    std::size_t bytes_ = 0;
    std::size_t messages_ = 0;
    std::deque<Message> items_;
    std::uint64_t pushed_ = 0;
    std::uint64_t dropped_ = 0;
};

}  // namespace plexus::daemon
