#pragma once
// Reading a recording made by `plexus record` (docs/RECORDING.md): the messages that reached the
// recorded ports, each with the port it reached, the port that sent it, its times and its payload
// exactly as it was sent. For tests and notebooks; `plexus play` and `plexus record --info` use it.
// A Recording is used by one thread at a time.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "plexus/client.hpp"

namespace plexus {

/// One recorded message.
struct RecordedMessage {
    std::string port;                   ///< the recorded port it reached
    std::string source;                 ///< the port that sent it
    std::uint32_t sequence = 0;         ///< the low 32 bits of the writer's sequence number
    std::uint64_t sent_ns = 0;          ///< the writer's clock when it wrote it (ns since the Unix epoch)
    std::uint64_t arrived_ns = 0;       ///< the recording daemon's clock when it arrived (ditto)
    std::vector<std::uint8_t> payload;  ///< CBOR, exactly as sent
    /// The payload decoded, as Port::read gives it.
    Value value() const;
};

/// A connection into a recorded port, as the recording saw it.
struct RecordedConnection {
    std::string port;
    std::string source;
    std::string carrier;
    std::uint64_t messages = 0;
};

class Recording {
public:
    /// Opens a recording; a file that is not one, or is truncated or corrupt, throws an Error
    /// (refused, as what-if's exit status 4) whose message names the file offset where it went wrong.
    static Recording open(const std::string& path);
    Recording(Recording&&) noexcept;
    Recording& operator=(Recording&&) noexcept;
    ~Recording();

    /// The recorded ports, in the order the recording named them.
    std::vector<std::string> ports() const;
    std::vector<RecordedConnection> connections() const;
    /// The node whose daemon recorded it.
    std::string node() const;
    /// Messages in the file (over every port), and the first and last arrival times.
    std::uint64_t message_count() const;
    std::uint64_t start_ns() const;
    std::uint64_t end_ns() const;
    std::uint64_t size_bytes() const;
    /// The daemon's closing note (messages, lost_messages, reason...); empty when the recording
    /// did not end cleanly (the daemon died while recording).
    std::map<std::string, std::string> end_note() const;

    /// Calls `visit` for each message that reached one of `ports` (every recorded port when
    /// empty), in the order they arrived; stops when it returns false. Throws an Error naming the
    /// offset if the file turns out to be corrupt on the way.
    void for_each(const std::function<bool(const RecordedMessage&)>& visit,
                  const std::vector<std::string>& ports = {}) const;
    /// All of them at once (for small recordings).
    std::vector<RecordedMessage> messages(const std::vector<std::string>& ports = {}) const;

private:
    struct State;
    explicit Recording(std::unique_ptr<State> state);
    std::unique_ptr<State> state_;
};

}  // namespace plexus
