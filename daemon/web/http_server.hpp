#pragma once
// Threading: the daemon's one thread (the views it serves read the daemon's state unlocked).
//
// plexusd's web endpoint (docs/WEB.md): `--http HOST:PORT`. HTTP/1.1 by Boost.Beast, GET and
// HEAD only, read-only views. Bounded on purpose: a connection limit, a header limit, a time
// limit for a request to arrive and for a response to leave, a backlog limit per stream client;
// every refusal counted (HttpCounters) and the daemon's data path unaffected.

#include <memory>
#include <string>

#include <boost/asio/ssl/context.hpp>

#include "access.hpp"
#include "control/control_host.hpp"
#include "event_stream.hpp"
#include "http_config.hpp"
#include "http_counters.hpp"
#include "net/asio.hpp"
#include "net/shm_region.hpp"
#include "routes.hpp"
#include "system_view.hpp"

namespace plexus::daemon::web {

class HttpServer {
public:
    HttpServer(asio::io_context& io, HttpConfig config, ControlHost& host, const ShmUsage& shm);
    ~HttpServer();

    /// Binds `config.listen`; an Error says why it cannot.
    proto::Status bind();
    /// Starts accepting.
    void start();
    /// Stops accepting and ends the streams (the daemon shuts down).
    void stop();
    /// HOST:PORT it listens on (the port the kernel gave for port 0).
    std::string address() const;
    /// True when it speaks HTTPS: beyond loopback with the secret (bind()).
    bool tls() const { return tls_ != nullptr; }
    /// With the secret alone: the SHA-256 of the self-signed certificate made at this start.
    const std::string& fingerprint() const { return fingerprint_; }
    const HttpCounters& counters() const { return counters_; }

private:
    Task<void> accept();
    Task<void> serve(asio::ip::tcp::socket socket);
    /// Reads requests from `stream` and answers them until it closes (plain or HTTPS).
    template <class Stream>
    Task<void> answer_requests(Stream& stream, const asio::ip::address& remote);
    /// Answers 503 to a connection over the limit, briefly, then closes it.
    Task<void> refuse_busy(asio::ip::tcp::socket socket);

    asio::io_context& io_;
    HttpConfig config_;
    ControlHost& host_;
    asio::ip::tcp::acceptor acceptor_;
    std::unique_ptr<asio::ssl::context> tls_;  ///< HTTPS; null: plain HTTP (loopback, or --insecure)
    std::string fingerprint_;                  ///< of a self-signed certificate (no identity)
    Access access_;
    HttpCounters counters_;
    SystemView system_;
    Routes routes_;
    EventStream stream_;
    std::size_t refusing_ = 0;  ///< 503 answers being written now (bounded too)
    bool stopped_ = false;
};

}  // namespace plexus::daemon::web
