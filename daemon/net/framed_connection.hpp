#pragma once
// Threading: one io_context thread; each connection runs one reader and one writer coroutine.

#include <sys/uio.h>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "asio.hpp"
#include "byte_stream.hpp"
#include "frame_reader.hpp"
#include "outbox.hpp"
#include "peer_limits.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/hello.hpp"
#include "session_rings.hpp"
#include "signal.hpp"

namespace plexus::daemon {

/// A socket speaking Plexus frames: hello exchange, a reader coroutine handing frames to the
/// subclass, a writer coroutine gathering the outbox into few system calls, and one orderly close.
class CallTable;
class TlsContext;

class FramedConnection : public std::enable_shared_from_this<FramedConnection> {
public:
    FramedConnection(Socket socket, std::size_t max_frame, std::function<void()> on_space);
    virtual ~FramedConnection() = default;
    FramedConnection(const FramedConnection&) = delete;
    FramedConnection& operator=(const FramedConnection&) = delete;

    /// With the deployment secret, every TCP link is TLS 1.3 keyed by it (proto/tls_psk.hpp): the
    /// handshake proves both ends hold the secret, and nothing is sent before it is over, not even
    /// the hellos. A plain TCP peer is told why it is refused and nothing else; a Unix-socket peer is
    /// trusted by the socket's permissions. Call before start().
    void require_secret(std::optional<proto::Secret> secret, proto::Party party = proto::Party::accepting);
    /// An accepted peer that has not completed its hello (and its proof, when one is needed) this
    /// long after start() is cut off: a peer that connects and says nothing would otherwise hold a
    /// socket and a session for good. Zero: no limit. Call before start().
    void set_handshake_timeout(std::chrono::milliseconds timeout) { handshake_timeout_ = timeout; }
    /// Sends our hello and starts reading and writing (after the TLS handshake when there is one).
    void start(const proto::Hello& mine);
    /// Queues a whole control frame.
    void send(proto::Bytes frame);
    /// Wakes the writer after messages were added to an outbox source.
    void wake() { wake_.notify(); }
    /// Closes now; queued frames are dropped.
    void close(const std::string& reason);
    /// Writes what is queued, then closes our side and waits (briefly) for the peer to close.
    void close_when_drained();
    /// Tells the peer why (an error frame), then closes: for peers that broke the protocol.
    void fail(const std::string& reason);

    bool closed() const { return closed_; }
    /// With identities (proto/identity.hpp): what the peer's certificate names, checked against
    /// its hello (a peer cannot say it is another node than its certificate's). nullopt otherwise.
    const std::optional<proto::Subject>& peer_subject() const { return stream_.peer_subject(); }
    bool hello_received() const { return peer_hello_.has_value(); }
    const proto::Hello& peer_hello() const { return *peer_hello_; }
    const std::string& description() const { return description_; }
    void set_description(std::string text) { description_ = std::move(text); }
    Outbox& outbox() { return outbox_; }
    asio::any_io_executor executor() { return stream_.socket().get_executor(); }
    /// Keeps the socket's send buffer at `bytes` from now on (never raised for large messages):
    /// for links that must not hold much in the kernel, where it would only add delay.
    void limit_send_buffer(int bytes);
    /// Marks every packet this socket sends with `dscp` and its socket priority (packet_marks.hpp);
    /// an Error says why the kernel refused. Nothing to do on a Unix socket.
    proto::Status mark_packets(int dscp);
    /// True for a Unix-socket peer (a client on this machine), which can be given descriptors.
    bool is_local();
    /// The peer's IP address for a TCP peer; nullopt for a Unix-socket one.
    std::optional<asio::ip::address> remote_ip();
    /// This end's IP address for a TCP connection (the address the peer reached); nullopt otherwise.
    std::optional<asio::ip::address> local_ip();
    /// True when the peer has closed or reset the connection, even with unread data left: lets a
    /// session that stopped reading (back-pressure) notice that its client died.
    bool peer_hung_up();
    /// Calls came or went on this socket: `calls` is told when it closes (call_table.hpp).
    void carry_calls(std::shared_ptr<CallTable> calls) { calls_ = std::move(calls); }
    /// Waits until the peer's hello arrived or the connection closed.
    Task<bool> wait_for_hello(std::chrono::steady_clock::duration timeout);

    /// The peer asked for shared-memory rings and they are made: from now on its frames are read
    /// from `rings`; ours go on the socket up to `answer` (sent with the rings' descriptors) and
    /// into the rings after it. Call while handling the peer's `rings` frame (on_frame_now). False
    /// (and the peer failed) when it sent anything on the socket after that frame.
    bool use_rings(std::unique_ptr<SessionRings> rings, proto::Bytes answer);
    /// The rings in use, or null (a socket-only session).
    const SessionRings* rings() const { return rings_.get(); }
    /// Counts this connection against its peer's limits (peer_limits.hpp) until it closes: its
    /// handshake ends with the peer's hello, and a failed proof of the secret is the peer's.
    void count_against_peer(std::unique_ptr<PeerLimits::Ticket> ticket) { peer_ticket_ = std::move(ticket); }

protected:
    /// The call table told of this socket's end; null until a call came or went on it.
    CallTable* call_table() const { return calls_.get(); }
    /// Called for the peer's hello; an error refuses the peer (it is told why).
    virtual proto::Status on_hello(const proto::Hello& hello) = 0;
    enum class FrameAction { handled, stop, wait };
    /// Called first for every frame after the hello, without a coroutine: handle it now, stop
    /// reading (after fail() or close()), or `wait` to have on_frame() called, which may suspend.
    virtual FrameAction on_frame_now(InFrame& /*frame*/) { return FrameAction::wait; }
    /// Called for frames on_frame_now() left; return false to stop reading (after fail()).
    virtual Task<bool> on_frame(InFrame frame) = 0;
    /// Called once, after the connection closed for any reason.
    virtual void on_closed(const std::string& reason) = 0;
    /// Called when a peer failed to prove it holds the deployment secret (its TLS handshake failed,
    /// or it did not start one), before it is cut off.
    virtual void on_auth_failure(const std::string& /*reason*/) {}
    /// Called when a peer did not complete its handshake in time (before it is cut off).
    virtual void on_handshake_timeout() {}
    /// Called when the peer broke the protocol where only this class sees it (bytes that are no
    /// frame, bytes on the socket after the switch to rings, an impossible ring position), before
    /// it is cut off.
    virtual void on_protocol_error() {}
    /// Called when a record of the encrypted link failed its check (bytes altered, injected or
    /// replayed on the way), before the link is closed.
    virtual void on_tls_refused(const std::string& /*reason*/) {}

private:
    /// Why the peer's hello does not match its certificate, on a link between identities: a name
    /// server's hello needs a name server's certificate, a node's hello names the node of its
    /// certificate. nullopt when it matches or there are no certificates.
    std::optional<std::string> certificate_mismatch(const proto::Hello& hello) const;
    Task<void> read_loop();
    Task<void> write_loop();
    /// Sends what the socket takes of `batch` (at least one byte) with its descriptors attached.
    Task<proto::Result<std::size_t>> send_with_fds(const Batch& batch);
    /// Sends what the socket takes of `pieces` (at least one byte) with `fds` attached.
    Task<proto::Result<std::size_t>> send_with_fds(const std::vector<iovec>& pieces,
                                                   const std::vector<int>& fds);
    /// Drops the first `sent` bytes from `buffers`.
    static void consume(std::vector<asio::const_buffer>& buffers, std::size_t sent);
    Task<void> close_after(std::chrono::steady_clock::duration grace);
    /// After a failure, while the error frame drains: reads and drops what the peer still sends,
    /// so that its close ends the session (and frees its ports) at once rather than after the grace.
    Task<void> discard_until_peer_closes();
    /// Cuts the peer off if its handshake is not over within handshake_timeout_.
    Task<void> watch_handshake();
    /// On a link between identities: closes it when the peer's certificate is revoked after its
    /// handshake (crl.pem is looked at every revocation_check_interval).
    Task<void> watch_revocation();
    /// Runs the TLS handshake when the link needs one, then sends our hello and starts the reader
    /// and the writer.
    Task<void> begin();
    /// The TLS handshake; an accepting end first reads two bytes to tell a TLS peer from a plain
    /// one (which is let through to be refused in words). False when the peer was refused.
    Task<bool> secure_link();
    /// The peer's hello arrived: checks it. False when the peer was refused.
    Task<bool> take_hello(InFrame& frame);
    /// Accepts the peer.
    bool accept_peer(proto::Hello hello);
    /// Counts, logs, waits a while (a peer guessing cannot go fast), then refuses the peer: with an
    /// error frame when the link can carry one (`can_tell`), else by closing.
    Task<void> refuse_unauthenticated(std::string reason, bool can_tell = true);
    /// With rings, the socket only tells that the peer closed: watches it for that.
    Task<void> watch_socket();
    /// With rings, sends the batch's descriptors on the socket (with one byte), ahead of the frames
    /// that name them, which go into the rings.
    Task<proto::Status> send_descriptors(const std::vector<int>& fds);

    ByteStream stream_;
    Socket& socket_;  ///< stream_'s socket: for what only a socket does
    FrameReader reader_;
    Outbox outbox_;
    Signal wake_;
    Signal hello_signal_;
    std::optional<proto::Hello> peer_hello_;
    std::optional<proto::Secret> secret_;
    std::shared_ptr<TlsContext> tls_;               ///< set with a secret: TCP links need TLS
    proto::Party party_ = proto::Party::accepting;  ///< which end we are: the TLS client or server
    bool needs_tls_ = false;                        ///< decided at start(): a secret and a TCP peer
    proto::Hello mine_;
    std::string description_;
    bool closed_ = false;
    bool draining_ = false;
    bool large_send_buffer_ = false;  ///< raised after the first large message
    std::chrono::milliseconds handshake_timeout_{0};
    std::shared_ptr<CallTable> calls_;     ///< set once a call came or went on this socket
    std::shared_ptr<SessionRings> rings_;  ///< the shared-memory rings, once the peer asked for them
    bool writing_rings_ = false;           ///< the rings answer went: our frames go into the rings
    std::unique_ptr<PeerLimits::Ticket> peer_ticket_;
};

}  // namespace plexus::daemon
