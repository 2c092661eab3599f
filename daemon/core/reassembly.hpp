#pragma once
// Threading: owned by the daemon's one thread; no locking, no sockets.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "message.hpp"
#include "plexus/proto/datagram.hpp"

namespace plexus::daemon {

/// Bytes held by unfinished messages of all streams of a daemon together: a sender that starts
/// many large messages and never finishes them cannot make the receiver hold more than this.
struct ReassemblyBudget {
    std::size_t max_bytes = 64u * 1024u * 1024u;
    std::size_t bytes = 0;
};

/// What a stream has seen, for `plexus stats`.
struct DatagramCounters {
    std::uint64_t datagrams = 0;   ///< datagrams taken (well formed, for this stream)
    std::uint64_t messages = 0;    ///< whole messages handed on, in order
    std::uint64_t lost = 0;        ///< messages never completed: sequence gaps, timeouts, no budget
    std::uint64_t late = 0;        ///< datagrams of a message already handed on or counted lost
    std::uint64_t incomplete = 0;  ///< of `lost`, messages some fragments of which had arrived
};

/// The receiving end of one datagram stream (a udp connection, or an mcast group): puts fragments
/// together and hands on whole messages in order. Best effort, never torn: a message some of whose
/// fragments are missing is counted lost and never handed on; a message that arrives after a later
/// one was handed on is dropped as late rather than delivered out of order.
///
/// Loss accounting: messages are numbered 0, 1, 2... per stream. When message m completes, every
/// message before it not yet handed on is counted lost. An unfinished message older than the
/// timeout is counted lost (with those before it) when `expire` runs. Losses at the very end of a
/// stream, with nothing after them, are not seen.
class DatagramStream {
public:
    using Clock = std::chrono::steady_clock;
    struct Limits {
        std::size_t max_unfinished = 8;  ///< messages being put together at once
        Clock::duration timeout = std::chrono::seconds(1);
        /// Take the first message seen as the start (a multicast group joined mid-stream), rather
        /// than counting every message before it as lost.
        bool start_anywhere = false;
        /// With start_anywhere: no message below this one starts the stream (they count as late).
        /// The sender's next number when the receiver joined: an old datagram replayed cannot be
        /// the first message handed on.
        std::uint64_t first = 0;
    };

    DatagramStream(std::shared_ptr<ReassemblyBudget> budget, Limits limits)
        : budget_(std::move(budget)), limits_(limits) {}
    ~DatagramStream();
    DatagramStream(const DatagramStream&) = delete;
    DatagramStream& operator=(const DatagramStream&) = delete;

    /// Takes one decoded datagram; returns the message it completed, if any (a record).
    std::optional<Message> take(const proto::DatagramView& datagram, Clock::time_point now);
    /// Counts as lost the unfinished messages older than the timeout; frees their bytes.
    void expire(Clock::time_point now);

    const DatagramCounters& counters() const { return counters_; }
    /// Bytes this stream holds in unfinished messages.
    std::size_t held_bytes() const;

private:
    struct Unfinished {
        std::shared_ptr<Chunk> storage;
        std::uint64_t fragment_size = 0;
        std::vector<bool> arrived;
        std::uint64_t missing = 0;
        Clock::time_point started;
    };
    /// Counts the messages before `message` that were not handed on as lost, and forgets them.
    void skip_to(std::uint64_t message);
    void release(Unfinished& unfinished);

    std::shared_ptr<ReassemblyBudget> budget_;
    Limits limits_;
    std::uint64_t next_ = 0;  ///< the oldest message neither handed on nor counted lost
    bool started_ = false;    ///< with start_anywhere: a first datagram has set next_
    std::map<std::uint64_t, Unfinished> unfinished_;
    DatagramCounters counters_;
};

}  // namespace plexus::daemon
