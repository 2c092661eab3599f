#pragma once
// Threading: its shard's thread (`--threads`: a data thread, or the control thread); requests,
// calls and answers are served on the control thread (net/handler_gate.hpp).

#include <map>
#include <memory>
#include <vector>

#include "../core/inlet.hpp"
#include "../core/permissions.hpp"
#include "framed_connection.hpp"
#include "peer_limits.hpp"
#include "plexus/proto/control.hpp"
#include "shm_region.hpp"

namespace plexus::daemon {

class SessionHost;

/// A connection accepted by the daemon: a local client (Unix socket), the CLI or a component over
/// TCP, another daemon forwarding a request, or another daemon's link carrying one connection.
class Session : public FramedConnection {
public:
    /// `shard`: the daemon's thread the socket's io_context runs on (0: the control thread).
    Session(Socket socket, SessionHost& daemon, std::uint64_t id, std::size_t shard = 0);

    std::uint64_t id() const { return id_; }
    std::size_t shard() const { return shard_; }
    const std::string& role() const { return role_; }
    bool is_link() const { return link_port_ != nullptr; }
    const std::shared_ptr<Port>& link_port() const { return link_port_; }
    const std::shared_ptr<Inlet>& link() const { return link_; }
    /// A local client's user, as the kernel gave it for the Unix socket (the daemon sets it).
    void set_local_user(uid_t uid) { local_user_ = uid; }
    /// Who this session is to the permissions (core/permissions.hpp): a local client's user; a
    /// TCP peer's node, from its certificate with identities, else from its hello.
    Principal principal() const;

    // A client's ports and shared-memory regions. The control plane changes them only through
    // these calls.
    /// Takes a port this client opened: gives it the next handle, makes its queue a source of the
    /// outbox and wakes the writer when it has something to read. Returns the handle.
    std::uint64_t add_port(std::shared_ptr<Port> port);
    /// The port of `handle`, forgotten with its outbox source and region; null if there is none.
    std::shared_ptr<Port> take_port(std::uint64_t handle);
    /// Every port still open, forgotten (the session is closing).
    std::vector<std::shared_ptr<Port>> take_ports();
    bool has_port(std::uint64_t handle) const { return ports_.contains(handle); }
    /// The port of `handle`; null if this client has none with it.
    std::shared_ptr<Port> port(std::uint64_t handle) const {
        const auto it = ports_.find(handle);
        return it == ports_.end() ? nullptr : it->second;
    }

    /// The client said it maps shared-memory regions: it may now be sent data_shm frames.
    void enable_shm() { maps_shm_ = true; }
    bool maps_shm() const { return maps_shm_; }
    /// The region port `handle` writes its large payloads through; null if it has none.
    std::shared_ptr<ShmRegion> shm_region(std::uint64_t handle) const;
    /// Gives the client `region` for port `handle`; its frame goes out before any later reply.
    void add_shm_region(std::uint64_t handle, std::shared_ptr<ShmRegion> region);

    /// Makes this session the receiving end of a connection into `port`.
    void become_link(std::shared_ptr<Inlet> link);
    /// Keeps `thing` (a udp connection's datagram stream) alive for as long as the link is.
    void hold_while_linked(std::shared_ptr<void> thing) { held_ = std::move(thing); }
    /// What this session counts against its peer's limits (net/peer_limits.hpp), until it closes.

protected:
    proto::Status on_hello(const proto::Hello& hello) override;
    FrameAction on_frame_now(InFrame& frame) override;
    Task<bool> on_frame(InFrame frame) override;
    void on_closed(const std::string& reason) override;
    void on_auth_failure(const std::string& reason) override;
    void on_handshake_timeout() override;
    void on_protocol_error() override;
    void on_tls_refused(const std::string& reason) override;

private:
    enum class DataOutcome { delivered, blocked, stop };
    struct Incoming {
        std::uint64_t handle;
        Message message;  ///< one record or a batch
    };
    /// The handle and record(s) of a data or data_batch frame; fails the session if malformed.
    std::optional<Incoming> decode_incoming(InFrame& frame);
    /// The message of a data_shm frame: its payload left in shared memory when every reader of the
    /// port can take it from there, else copied out of it now. Fails the session if malformed.
    std::optional<Incoming> decode_shm(InFrame& frame);
    /// True when every connection out of `port` goes, unwatched and unarbitrated, to a local client
    /// that maps regions: only then may a message keep its payload in shared memory.
    bool passes_shm(const Port& port) const;
    /// True while this client leaves so many shm_free frames unread that its data_shm frames must wait.
    bool frees_pile_up();
    /// A shm_release frame: the client is done with its oldest data_shm messages.
    bool on_release(const InFrame& frame);
    /// A `rings` frame: moves this session to shared-memory rings, or says why not.
    bool on_rings(const InFrame& frame);
    /// True if every record is well formed and written by `expected`; else fails the session with
    /// "message from port 'x' <writer> <expected>".
    bool check_sources(const Message& message, const std::string& expected, std::string_view writer);
    /// Routes a data frame now if nothing holds it back. Decoding twice when blocked is fine:
    /// blocking is the slow path by definition.
    DataOutcome try_deliver(InFrame& frame);
    /// Delivers what fits of `message` into `room` messages (via `deliver`); a batch that does not
    /// fit is cut, and the frame remembers how much of it went. Blocked when something is left.
    template <typename Deliver>
    DataOutcome deliver_within(InFrame& frame, const Message& message, std::size_t room, Deliver deliver);
    Task<bool> on_data(InFrame frame);
    /// A call frame: from a caller's client, routed to the server its port's arbitration selects;
    /// on a link, into the served port. False when the session was failed for a malformed one.
    bool on_call(const InFrame& frame);
    /// An answer frame: from a server's client, for a call delivered to it.
    bool on_answer(const InFrame& frame);
    Task<void> serve(proto::Request request);
    /// A call or answer frame, served on the control thread (where the call table is); false when
    /// the session was failed for it.
    Task<bool> on_call_frame(InFrame frame);
    Task<void> wait_for_space();

    SessionHost& daemon_;
    std::uint64_t id_;
    std::optional<uid_t> local_user_;
    std::size_t shard_;
    /// Requests being served: a peer that sends requests without reading the replies is held back
    /// (its socket no longer read) once this many are in progress, so replies cannot pile up.
    std::size_t requests_in_flight_ = 0;
    Signal request_done_;
    std::string role_;
    std::shared_ptr<Port> link_port_;
    std::shared_ptr<Inlet> link_;
    std::shared_ptr<void> held_;
    /// Ports this session opened, by the handle its data frames carry.
    std::map<std::uint64_t, std::shared_ptr<Port>> ports_;
    std::uint64_t next_handle_ = 1;
    bool maps_shm_ = false;
    /// The shared-memory region of each port this client writes through one, by handle.
    std::map<std::uint64_t, std::shared_ptr<ShmRegion>> shm_regions_;
};

}  // namespace plexus::daemon
