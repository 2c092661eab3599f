#pragma once
// Threading: one io_context thread; at most one read and one write in flight at a time (a
// connection's reader and writer coroutines).

#include <memory>
#include <optional>
#include <tuple>
#include <vector>

#include "asio.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/identity.hpp"

struct x509_st;

namespace plexus::daemon {

class TlsContext;

/// The bytes of a connection: a socket's, or, once start_tls() succeeded, the plain bytes of a TLS
/// session over it. FramedConnection and FrameReader read and write through it and need not know
/// which; what only a socket does (options, descriptors on a Unix socket, waits) goes to socket().
class ByteStream {
public:
    explicit ByteStream(Socket socket);
    ~ByteStream();
    ByteStream(const ByteStream&) = delete;
    ByteStream& operator=(const ByteStream&) = delete;

    /// True for an error of the TLS layer (a record that failed its check), not of the socket.
    static bool is_tls_error(const boost::system::error_code& error);
    /// True for a TLS error that is an alert the peer sent ("certificate revoked": it refused this
    /// end), not a record that failed its check here.
    static bool is_peer_alert(const boost::system::error_code& error);

    Socket& socket() { return socket_; }
    bool encrypted() const { return tls_ != nullptr; }
    /// What the peer's certificate names, once start_tls() succeeded on a link between identities
    /// (proto/identity.hpp); nullopt on a link keyed by the secret or a plain one.
    const std::optional<proto::Subject>& peer_subject() const { return peer_subject_; }
    /// The certificate behind peer_subject() (checked at the handshake), to be checked again when
    /// the revocation list changes; null when there is none.
    x509_st* peer_certificate() const { return peer_certificate_.get(); }

    /// Runs the TLS handshake as the `accepting` or the connecting end; `first` are bytes of the
    /// peer's already read from the socket (the listener looked at them). An Error says why it
    /// failed (the peer holds another secret, or speaks no TLS).
    Task<proto::Status> start_tls(TlsContext& context, bool accepting, proto::ByteView first = {});
    /// Bytes read from the socket that the next reads give first (a listener looked at them and
    /// found a plain peer).
    void give_back(proto::ByteView first) { given_back_.assign(first.begin(), first.end()); }

    /// Reads what is there, at least one byte. A TLS session the peer ended without its
    /// close_notify reads as an end of stream: frames delimit themselves, so a cut can only end a
    /// connection early, and the reader tells a cut inside a frame from a close between frames.
    Task<std::tuple<boost::system::error_code, std::size_t>> read_some(asio::mutable_buffer buffer);
    /// Writes all of `buffers`.
    Task<std::tuple<boost::system::error_code, std::size_t>> write(
        const std::vector<asio::const_buffer>& buffers);

private:
    Task<std::tuple<boost::system::error_code, std::size_t>> read_tls(asio::mutable_buffer buffer);
    Task<std::tuple<boost::system::error_code, std::size_t>> write_tls(
        const std::vector<asio::const_buffer>& buffers);
    Task<std::tuple<boost::system::error_code, std::size_t>> read_given_back(asio::mutable_buffer buffer);
    /// Keeps `error` as the session's end, tells the peer `alert` (0: none), and returns what a read
    /// that opened `got` bytes before it returns.
    Task<std::tuple<boost::system::error_code, std::size_t>> fail_tls(boost::system::error_code error,
                                                                      std::uint8_t alert, std::size_t got);
    /// Writes what is sealed to the socket. When another coroutine is at it already, the
    /// writer (`wait`) waits for it to end and then sends what is left: what write() encrypted must
    /// be on its way when write() returns, or `out` grows without bound under a peer that stops
    /// reading. The reader returns at once (the one flushing sends its bytes too): a reader that
    /// waited on a writer held back by its peer would stop reading, and two daemons that write to
    /// each other would wait on each other.
    Task<boost::system::error_code> flush_tls(bool wait);

    struct Tls;
    Socket socket_;
    std::unique_ptr<Tls> tls_;
    proto::Bytes given_back_;
    std::optional<proto::Subject> peer_subject_;
    struct CertificateFree {
        void operator()(x509_st* certificate) const;
    };
    std::unique_ptr<x509_st, CertificateFree> peer_certificate_;
};

}  // namespace plexus::daemon
