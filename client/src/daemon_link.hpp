#pragma once
// Threading: every DaemonLink member is safe to call from any thread. One thread of its own (the
// watcher) notices that the daemon went away, reconnects with back-off, and restores ports and
// connections. Lock order: DaemonLink::mutex_ before PortRecord::mutex, never the other way;
// DaemonLink::mutex_ is never held across a call into a Connection. A record's mutex is held while
// its held messages are written to the new connection, so that a port's own writes cannot overtake
// them (that write may block on the socket, or wait for a shared-memory region's reply: safe, as
// the connection's receiving thread takes neither lock). The whole order: client/src/LOCK_ORDER.md.
//
// This is the layer above Connection that STYLE.md item 4 asks for: Connection stays one socket
// that breaks for good; reconnection replaces it with a new one.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "connection.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::detail {

/// The body of an ok reply; throws Error (with the reply's code and reason) for any other.
nlohmann::json checked(const proto::Reply& reply);

/// An ok reply read as `Answer`, a reply struct of plexus/proto/operations.hpp; throws Error for a
/// refusal, and for an answer that does not decode (a peer that is not the plexusd we speak to).
template <class Answer>
Answer checked_as(const proto::Reply& reply) {
    auto decoded = Answer::decode(checked(reply));
    if (!decoded)
        throw Error(ErrorCode::refused, decoded.error().message);
    return std::move(*decoded);
}

/// A message a port wrote while its daemon was away, sent once the port is open again.
struct HeldMessage {
    std::uint64_t seq = 0;
    proto::Bytes payload;
};

/// While the daemon is away, a port keeps at most this many messages, or this many bytes,
/// whichever comes first; beyond them the oldest go (and are counted).
inline constexpr std::size_t held_messages_limit = 1000;
inline constexpr std::size_t held_bytes_limit = 8 * 1024 * 1024;

/// What the link keeps of one open port: enough to open it again, and where it lives now.
struct PortRecord {
    PortRecord(std::string name_, PortOptions options_) : name(std::move(name_)), options(options_) {}

    const std::string name;
    const PortOptions options;
    /// Changes whenever `connection` or `handle` change (the daemon went, or the port was opened
    /// again). A Port compares it with the value it cached: one load per message when all is well.
    std::atomic<std::uint64_t> generation{0};
    /// The last sequence number a call on this port used (calls may come from several threads).
    std::atomic<std::uint64_t> call_seq{0};

    std::mutex mutex;                        ///< guards what follows
    std::shared_ptr<Connection> connection;  ///< null while the daemon is away
    std::uint64_t handle = 0;
    std::deque<HeldMessage> held;
    std::size_t held_bytes = 0;
    std::uint64_t dropped = 0;  ///< held messages dropped (the oldest) to stay within the limits
    bool closed = false;

    /// Keeps a message written while the daemon is away; drops the oldest beyond the limits.
    void hold_locked(std::uint64_t seq, proto::ByteView payload, proto::ByteView tail);
};

/// A connection the component made with Client::connect, made again after a reconnection.
struct ConnectionSpec {
    std::string source;
    std::string destination;
    std::string carrier;
    bool persist = false;
};

/// The client's link to its local daemon: the current Connection, replaced when the daemon goes
/// away and comes back on the same socket path.
class DaemonLink {
public:
    /// Connects now (throws Error (refused) when no daemon runs there) and starts the watcher.
    explicit DaemonLink(std::string socket_path);
    ~DaemonLink();
    /// The largest frame body the daemon takes (the last daemon's, while it is away).
    std::uint64_t max_frame() const { return max_frame_.load(std::memory_order_relaxed); }
    DaemonLink(const DaemonLink&) = delete;
    DaemonLink& operator=(const DaemonLink&) = delete;

    /// Stops the watcher: no reconnection after this. Ports keep the connection they have.
    void stop();

    /// Sends a control request on the current connection; throws Error (refused, "the daemon at
    /// PATH is gone; reconnecting") while the daemon is away.
    proto::Reply request(const nlohmann::json& body, std::chrono::milliseconds timeout);
    /// Opens a port and records it, to open it again after a reconnection.
    std::shared_ptr<PortRecord> open(const std::string& name, PortOptions options,
                                     std::chrono::milliseconds timeout);
    /// Closes a port (on the daemon, if it is there) and forgets it.
    void close(const std::shared_ptr<PortRecord>& record, std::chrono::milliseconds timeout);
    /// Records a connection made, or forgets one undone, by Client::connect / disconnect.
    void remember(const ConnectionSpec& spec);
    void forget(const std::string& source, const std::string& destination);

    /// A Port found `connection` broken: the daemon is gone. Marks every port as away now (so
    /// their writes are held from here on) and wakes the watcher.
    void lost(const std::shared_ptr<Connection>& connection);
    /// Waits until `record` changes from `generation` (the port is open again) or `deadline`.
    bool wait_for_change(const PortRecord& record, std::uint64_t generation, Clock::time_point deadline);

    void on_state(std::function<void(ConnectionState)> callback);
    ConnectionState state() const;
    const std::string& socket_path() const { return path_; }

private:
    std::string gone_message() const;
    /// The watcher: waits for the connection to break, reconnects, restores, repeats.
    void watch();
    /// Blocks until the current connection hangs up, lost() is called, or stop(); between, retries
    /// connections that could not be made again yet. False when stopping.
    bool wait_for_loss(const std::shared_ptr<Connection>& connection);
    /// Marks every port away and the link down, if `connection` is still the current one.
    bool mark_down(const std::shared_ptr<Connection>& connection);
    /// Opens the ports again on `connection`, makes the connections again (waiting a little for
    /// peers that reconnect too), sends what was held, then makes it the current connection.
    void restore(const std::shared_ptr<Connection>& connection);
    /// Tries to make the connections in `left` on `connection`; keeps those not made; returns how
    /// many are left. Throws Error when the connection broke.
    std::size_t retry_connections(const std::shared_ptr<Connection>& connection,
                                  std::vector<ConnectionSpec>& left);
    void forget_locked(const std::string& source, const std::string& destination);
    /// Sleeps up to `delay`, or less if woken for stop(); false when stopping.
    bool pause(std::chrono::milliseconds delay);
    void announce(ConnectionState state);
    void wake();

    const std::string path_;
    /// The daemon's largest frame body (its hello), updated at every reconnection: Port::send
    /// refuses a message that would not fit, before holding or sending it.
    std::atomic<std::uint64_t> max_frame_{0};
    int wake_pipe_[2] = {-1, -1};  ///< written by lost() and stop() to wake the watcher from poll

    mutable std::mutex mutex_;
    std::condition_variable changed_;      ///< a port was opened again, or stop()
    std::shared_ptr<Connection> current_;  ///< null while the daemon is away
    ConnectionState state_ = ConnectionState::connected;
    bool stopping_ = false;
    std::vector<std::shared_ptr<PortRecord>> ports_;
    std::vector<ConnectionSpec> connections_;
    std::vector<ConnectionSpec> to_make_;  ///< after a reconnection, not made again yet
    std::function<void(ConnectionState)> callback_;

    std::thread watcher_;
};

}  // namespace plexus::detail
