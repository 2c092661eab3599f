#pragma once
// libplexus: the thin client library components link to talk to their local plexusd.
//
// Threading: a Client may be used from several threads, and so may different Ports of one Client
// (writes are serialized by a lock; a thread of the Client reads the socket and hands each port
// what came for it). One Port is used by one thread at a time for writing and one for reading:
// its sequence number and its read buffer are its own, without a lock.
//
// A Client outlives its daemon: when the daemon goes away, a thread of the Client reconnects to the
// same socket path (back-off 50 ms doubling to 2 s, +-25% jitter), opens its ports again and makes
// the connections it made again. Ports keep working meanwhile: writes are held (bounded), reads
// wait, sequence numbers continue.

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

namespace plexus {

/// A message payload: null, bool, integer, float, string, array, map, or binary (Value::binary(bytes)).
using Value = nlohmann::json;

/// Exit-status-like codes carried by every Error, matching the CLI's contract.
enum class ErrorCode { no = 1, usage = 2, timeout = 3, refused = 4 };

/// Anything that went wrong, with a message meant for a person.
class Error : public std::runtime_error {
public:
    Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
    ErrorCode code() const { return code_; }

private:
    ErrorCode code_;
};

/// Where the name server is, and how that was found.
struct NamesLocation {
    std::string address;  ///< HOST:PORT
    std::string how;      ///< "from --names", "found by multicast discovery on GROUP:PORT", ...
};

/// Finds the name server in the contract's order: `flag` (a --names option) if given, else
/// $PLEXUS_NAMES, else the "names" key of the config file ($PLEXUS_CONFIG, else
/// ~/.config/plexus/config.json, else /etc/plexus/config.json), else a multicast query that the
/// name server answers (group $PLEXUS_DISCOVERY, default 239.255.80.88:10101, "off" to skip; up to
/// 0.6 s), else 127.0.0.1:10100. Throws Error (usage) for a malformed config file or group.
NamesLocation find_names(const std::optional<std::string>& flag = std::nullopt);

/// The envelope of a received message.
struct Envelope {
    std::string source;         ///< the port that wrote it
    std::uint64_t seq = 0;      ///< per-source sequence number, from 1
    std::uint64_t time_ns = 0;  ///< send time, ns since the Unix epoch
};

/// A received message.
struct Received {
    Envelope envelope;
    Value data;
};

/// Hands back the buffer of a blob read from a port (Received::data.get_binary(), moved out) once
/// its bytes are no longer needed: a later large blob is received into it instead of into fresh
/// memory, which the kernel maps and zeroes page by page. Optional; a few buffers are kept at most.
void recycle_blob(std::vector<std::uint8_t>&& bytes);

/// How a port's reader queue behaves when its client reads slower than data arrives.
enum class QueuePolicy {
    strict,  ///< nothing is dropped: writers are slowed down
    latest,  ///< keep the newest `capacity` messages; older ones are dropped and counted
};

/// Options for opening a port.
struct PortOptions {
    QueuePolicy policy = QueuePolicy::strict;
    std::size_t capacity = 0;  ///< 0: the daemon's default
    bool serve = false;        ///< its client answers calls on it (Client::serve sets it)
};

/// The state of a Client's link to its daemon, as told to Client::on_state.
enum class ConnectionState {
    connected,     ///< the first connection, made by the constructor
    disconnected,  ///< the daemon went away; reconnecting in the background
    reconnected,   ///< the daemon is back: ports open again, connections made again, held writes sent
};

namespace detail {
class CallBook;
struct CallMaker;
class Connection;
class DaemonLink;
struct Inbox;
struct LoanSlot;
struct PortRecord;
struct ShmLease;
}  // namespace detail

class Client;

/// A buffer for one blob message, written in place and then sent (Port::loan, Port::send_loan).
/// With a daemon on this machine it lies in the port's shared memory: sent, it is not copied
/// again, and a reader on this machine reads it where it is (Port::read_view). Otherwise (a daemon
/// without shared memory, PLEXUS_SHM=0, a region full for longer than a moment, the daemon away)
/// it is ordinary memory, copied when sent. Movable, not copyable; one not sent is given back.
class Loan {
public:
    Loan(Loan&&) noexcept;
    Loan& operator=(Loan&&) noexcept;
    Loan(const Loan&) = delete;
    Loan& operator=(const Loan&) = delete;
    ~Loan();
    /// Where to write the message's bytes: exactly as many as asked for.
    std::span<std::uint8_t> bytes() { return bytes_; }
    /// True when the bytes lie in shared memory (the message will not be copied on this machine).
    bool in_shared_memory() const { return slot_ != nullptr; }

private:
    friend class Port;
    Loan() = default;
    std::shared_ptr<detail::LoanSlot> slot_;  ///< the shared-memory slot; null for a heap loan
    std::vector<std::uint8_t> heap_;          ///< the bytes of a heap loan
    std::span<std::uint8_t> bytes_;
};

/// A message read where it arrived (Port::read_view): a blob a writer on this machine put in
/// shared memory is read in place, without a copy, until the view goes (then its slot is released;
/// a reader that dies releases it too). Any other message is held as read(). Hold views briefly:
/// a writer's region fills while its slots are held. A release is a small frame to the daemon; let a
/// view go before this client's next write and it travels with that write instead of on its own
/// (which costs the daemon a wake-up when it sleeps). Movable, not copyable; usable from any thread.
class MessageView {
public:
    MessageView(MessageView&&) noexcept = default;
    MessageView& operator=(MessageView&&) noexcept = default;
    ~MessageView();
    const Envelope& envelope() const;
    /// The blob's bytes, read-only (in shared memory when in_place()); empty when the message is
    /// not a blob (then see value()).
    std::span<const std::uint8_t> bytes() const { return bytes_; }
    /// True when bytes() points into shared memory: no copy of the message was made here.
    bool in_place() const { return lease_ != nullptr; }
    /// The message as a Value (a copy, for a blob in place).
    Value value() const;

private:
    friend class Port;
    MessageView() = default;
    std::shared_ptr<detail::ShmLease> lease_;  ///< the slot held in place
    std::optional<Received> held_;             ///< a message that was not in place
    std::span<const std::uint8_t> bytes_;
};

/// A port opened by this client. Closing it (or destroying it) flushes what was written.
/// Aligned to a cache line: ports side by side in memory, one written by one thread and one read by
/// another, would otherwise slow each other down on every message (false sharing).
class alignas(64) Port {
public:
    Port(Port&&) noexcept;
    Port& operator=(Port&&) noexcept;
    Port(const Port&) = delete;
    Port& operator=(const Port&) = delete;
    ~Port();

    /// The port's name.
    const std::string& name() const { return name_; }
    /// Writes a value to every connection out of this port. With flush=false the message waits in
    /// a buffer until the next flushing write, flush(), or a full buffer: many messages, one send.
    /// While the daemon is away the message is held (up to 1,000 messages or 8 MiB per port, the
    /// oldest dropped beyond) and sent, in order, once reconnected; it neither throws nor blocks.
    void write(const Value& value, bool flush = true);
    /// Writes a blob, the same message as write(Value::binary(bytes)) where bytes are `head` then
    /// `body`, read from where they are during the call: no Value is built and the two are not
    /// joined first, so a large `body` (an image, an array) is copied once, into the socket or the
    /// shared-memory slot. Neither is used after the call returns. `head` is for a small header
    /// (a .npy header, say) and may be empty.
    void write_blob(std::span<const std::uint8_t> head, std::span<const std::uint8_t> body,
                    bool flush = true);
    /// Writes a payload already encoded as CBOR, sent as it is: what `plexus play` replays from a
    /// recording (whose chunks are checked when read). Bytes that are not one CBOR value reach the
    /// readers as a message they cannot decode.
    void write_encoded(std::span<const std::uint8_t> cbor, bool flush = true);
    /// Sends what write(..., false) buffered.
    void flush();
    /// Calls a server: sends `value` as a request along this port's connections to the one server
    /// its arbitration selects now (the first connection to a served port whose route constraint,
    /// `send.portmonitor+constraint.X`, holds over this port's events), and waits up to `timeout`
    /// for the answer. Throws Error: ErrorCode::timeout when no answer came in time; refused with
    /// the reason when no server was selectable, the server's handler failed, or the server, its
    /// daemon or the link went away with the call. Safe from several threads at once.
    Received request(const Value& value, std::chrono::milliseconds timeout);
    /// The same without waiting: the future holds the answer, or the Error. It is always completed:
    /// by the answer, by the daemon's timeout, or by the loss of the daemon.
    std::future<Received> request_async(const Value& value, std::chrono::milliseconds timeout);
    /// The same, calling `done` once with the answer (`reply` set) or the Error (`error` set). It
    /// runs on the client's receiving thread (or on this one, when the call cannot be sent): keep
    /// it short, never wait there for another answer, and never destroy the Client there.
    void request_then(const Value& value, std::chrono::milliseconds timeout,
                      std::function<void(Received* reply, const Error* error)> done);
    /// Waits up to `timeout` for the next message delivered to this port (also while the daemon is
    /// away: then it waits for the reconnection rather than throwing).
    std::optional<Received> read(std::chrono::milliseconds timeout);
    /// The same, but a blob that a writer on this machine put in shared memory is not copied: the
    /// view reads it where it is, and releases it when it goes (MessageView).
    std::optional<MessageView> read_view(std::chrono::milliseconds timeout);
    /// A buffer of `size` bytes for one blob message, in this port's shared memory when it can be
    /// (Loan): fill it, then send_loan() it. The copying write() stays the plain way to write.
    Loan loan(std::size_t size);
    /// Sends a loan filled in place as one blob message (what write_blob({}, bytes) would send).
    void send_loan(Loan&& loan, bool flush = true);
    /// Messages written while the daemon was away and dropped (the oldest) beyond the bound.
    std::uint64_t dropped_while_disconnected() const;
    /// Tells the daemon counters this client keeps about the port (a map of names to whole
    /// numbers, at most 64), shown by `plexus stats` under the port as "reported"; each report
    /// replaces the last. A bridge reports what it could not convert or deliver. Returns false
    /// while the daemon is away (report again later: the port opened again starts with none).
    bool report(const Value& counters);
    /// Closes the port now (after flushing); further use throws.
    void close();
    bool is_open() const { return link_ != nullptr; }

private:
    friend class Client;
    friend class Service;
    friend struct detail::CallMaker;
    /// The connection and handle the port lives on now; null connection while the daemon is away.
    std::pair<std::shared_ptr<detail::Connection>, std::uint64_t> current() const;
    Port(std::shared_ptr<detail::DaemonLink> link, std::shared_ptr<detail::PortRecord> record);
    /// Writes one encoded message, or holds it while the daemon is away.
    void send(std::uint64_t seq, std::span<const std::uint8_t> payload, std::span<const std::uint8_t> tail,
              bool flush);
    /// Fills ready_ from the connection, waiting up to `timeout` (across a reconnection).
    bool take(std::chrono::milliseconds timeout);
    /// True when a message is in ready_, taken now if needed (waiting up to `timeout`); throws
    /// Error (usage) on a closed port.
    bool next_ready(std::chrono::milliseconds timeout);
    bool take_slow(std::chrono::steady_clock::time_point deadline);

    std::shared_ptr<detail::DaemonLink> link_;
    std::shared_ptr<detail::PortRecord> record_;  ///< what the link re-opens; where the port lives now
    std::string name_;
    // The writing side's copy of where the port lives, valid while record_'s generation equals
    // generation_: a write checks with one load instead of a lock. The reading side has its own
    // copy, because a port is written by one thread and read by another.
    std::shared_ptr<detail::Connection> connection_;
    std::uint64_t handle_ = 0;
    std::uint64_t generation_ = 0;
    std::shared_ptr<detail::Connection> read_connection_;
    std::uint64_t read_handle_ = 0;
    std::uint64_t read_generation_ = 0;
    std::uint64_t next_seq_ = 1;
    /// Messages taken from the connection in one go and not yet read: one lock per batch of
    /// messages instead of one per message.
    std::unique_ptr<detail::Inbox> ready_;
};

/// A call that reached a served port: the request, and the way to answer it. Answer once, from any
/// thread, now or later; a Call destroyed unanswered fails the call (its caller hears that the
/// handler returned without answering). Movable, not copyable.
class Call {
public:
    Call(Call&&) noexcept;
    Call& operator=(Call&&) noexcept;
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;
    ~Call();

    /// The request: its data and envelope (the caller's port, seq, time).
    const Received& request() const { return request_; }
    /// The port it reached.
    const std::string& port() const { return port_; }
    /// Answers with `value`. Throws Error (usage) if already answered.
    void reply(const Value& value);
    /// Answers with a failure: the caller's Error says `reason`. Throws Error (usage) if already answered.
    void fail(const std::string& reason);
    bool answered() const { return answered_; }

private:
    friend struct detail::CallMaker;
    Call(std::shared_ptr<detail::Connection> connection, std::uint64_t id, std::string port,
         Received request);
    /// Sends the answer frame; marks the call answered first (a second answer throws).
    void send(const std::vector<std::uint8_t>& frame);
    std::shared_ptr<detail::Connection> connection_;
    bool answered_ = false;
    std::uint64_t id_ = 0;
    std::string port_;
    Received request_;
};

/// Answers the calls of one served port, each on the Service's thread, until destroyed (which
/// closes the port: calls on their way are then answered by the daemon as lost).
class Service {
public:
    ~Service();
    Service(Service&&) noexcept;
    Service& operator=(Service&&) = delete;
    Service(const Service&) = delete;
    Service& operator=(const Service&) = delete;
    const std::string& port() const;
    /// Calls handed to the handler so far.
    std::uint64_t calls() const;

private:
    friend class Client;
    struct State;
    explicit Service(std::unique_ptr<State> state);
    std::unique_ptr<State> state_;
};

/// Calls a function for every message of a port, on a thread of its own, until destroyed. The
/// Subscription is the port's reader: the Port must outlive it and must not be read, moved or
/// closed while it runs (destroy the Subscription first). A callback that throws ends it.
class Subscription {
public:
    Subscription(Port& port, std::function<void(const Received&)> callback);
    ~Subscription();
    Subscription(const Subscription&) = delete;
    Subscription& operator=(const Subscription&) = delete;

private:
    std::jthread thread_;
};

/// A connection to the local daemon.
class Client {
public:
    struct Options {
        std::string socket;  ///< empty: $PLEXUS_SOCKET, else the per-user runtime path
        std::chrono::milliseconds request_timeout{10000};
    };

    /// Connects to the local daemon; throws Error (refused) saying where it looked if none runs.
    Client();
    explicit Client(Options options);
    ~Client();
    Client(const Client&) = delete;
    Client& operator=(const Client&) = delete;

    /// Opens a port on the local daemon and registers it with the name server.
    Port open(const std::string& name, PortOptions options = {});
    /// Connects two ports (anywhere); carrier "" chooses local or tcp by where they live.
    /// Returns the carrier used.
    std::string connect(const std::string& source, const std::string& destination,
                        const std::string& carrier = "", bool persist = false);
    void disconnect(const std::string& source, const std::string& destination);
    /// Ports and connections, as the name server knows them: {"ports": [...], "connections": [...]}.
    Value list();
    /// Where a port lives ({"port","node","address"}); nullopt if it is not registered.
    std::optional<Value> lookup(const std::string& port);
    /// Counters of the local daemon, or of the daemon hosting `port`.
    Value stats(const std::string& port = "");
    /// Asks the daemon hosting `port` to answer; returns its node and address.
    Value ping(const std::string& port);
    /// Sends any control request and returns the reply body; throws Error when refused.
    Value request(const Value& body);
    /// Calls the service at `port` (a served port anywhere, or a port whose connections lead to
    /// servers) from a port of this client's own, `/plexus/call/...`, connected to it on first use
    /// and kept; as Port::request otherwise.
    Received request(const std::string& port, const Value& value, std::chrono::milliseconds timeout);
    std::future<Received> request_async(const std::string& port, const Value& value,
                                        std::chrono::milliseconds timeout);
    void request_then(const std::string& port, const Value& value, std::chrono::milliseconds timeout,
                      std::function<void(Received* reply, const Error* error)> done);
    /// Opens `port` to serve it: each call is answered with handler(request), on the Service's
    /// thread, one at a time; a handler that throws fails the call with what() as the reason.
    Service serve(const std::string& port, std::function<Value(const Received&)> handler);
    /// The same, but the handler takes the Call and answers it when it likes, from any thread (it
    /// may hand it to a pool and return at once).
    Service serve_calls(const std::string& port, std::function<void(Call)> handler);
    /// Asks a name server directly over TCP (works without a local daemon): {"op": "list"} or
    /// {"op": "lookup", "port": ...}. Returns the reply body; nullopt for a "no" answer.
    static std::optional<Value> ask_names(const std::string& names_address, const Value& body);
    /// The socket path this client is connected to.
    const std::string& socket_path() const { return socket_; }
    /// Calls `callback` (on the Client's reconnection thread) when the daemon goes away
    /// (disconnected) and when it is back and the ports and connections are restored (reconnected).
    /// While disconnected, control requests (open, connect, stats, ...) throw Error (refused, "the
    /// daemon at PATH is gone; reconnecting").
    void on_state(std::function<void(ConnectionState)> callback);
    /// The link's state now.
    ConnectionState state() const;

private:
    /// The port of this client that calls `target`, opened and connected on first use.
    Port& caller_for(const std::string& target);

    std::string socket_;
    std::shared_ptr<detail::DaemonLink> link_;
    struct Callers;
    std::shared_ptr<Callers> callers_;  ///< the ports Client::request made, by target
};

}  // namespace plexus
