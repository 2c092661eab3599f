#include "name_server.hpp"

#include <filesystem>
#include <fstream>

#include <spdlog/spdlog.h>

#include "../net/framed_connection.hpp"
#include "../net/keepalive.hpp"
#include "name_protocol.hpp"
#include "plexus/proto/discovery.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/name_operations.hpp"
#include "request_parser.hpp"
#include "state_file.hpp"

namespace plexus::daemon::names {

namespace {

using proto::ReplyCode;

/// One TCP client of the name server (a daemon, or a tool asking questions).
class NameSession : public FramedConnection {
public:
    NameSession(Socket socket, NameServer& server, std::uint64_t id)
        : FramedConnection(std::move(socket), server.max_frame(), {}), server_(server), id_(id) {}

protected:
    proto::Status on_hello(const proto::Hello&) override { return proto::Ok{}; }
    Task<bool> on_frame(InFrame frame) override {
        auto request = parse_session_request(frame.type, frame.fields);
        if (!request) {
            fail(request.error().message);
            co_return false;
        }
        if (!where_)
            where_ = SessionAddresses{remote_ip(), local_ip()};
        const auto& subject = peer_subject();
        send(proto::encode_reply(server_.answer(*request, id_, *where_, subject ? &*subject : nullptr)));
        co_return true;
    }
    void on_auth_failure(const std::string&) override { server_.count_auth_failure(); }
    void on_handshake_timeout() override { server_.count_handshake_timeout(); }
    void on_tls_refused(const std::string&) override { server_.count_tls_refused(); }
    void on_closed(const std::string& reason) override {
        spdlog::debug("names: session {} closed: {}", id_, reason);
        server_.session_closed(id_);
    }

private:
    NameServer& server_;
    std::uint64_t id_;
    std::optional<SessionAddresses> where_;  ///< both ends' addresses, read at the first request
};

}  // namespace

NameServer::NameServer(asio::io_context& io, NameServerConfig config)
    : io_(io),
      config_(std::move(config)),
      registry_(config_.grace),
      acceptor_(io),
      udp_(io),
      discovery_(io),
      peers_(std::make_shared<PeerLimits>(config_.peer_limits)),
      permissions_(config_.permissions) {
    registry_.set_mcast_range(config_.mcast_first, config_.mcast_count, config_.mcast_port);
}

void NameServer::refused(const std::string& peer, PeerLimits::Refusal refusal) {
    ++peers_refused_;
    peers_->log_refusal("names: ", peer, refusal);
}

NameServer::~NameServer() {
    stop();
}

proto::Status NameServer::start() {
    if (!config_.state_file.empty()) {
        // A state file that cannot be read is reported and does not stop the name server: the
        // persistent connections it lost are less harm than no name server at all.
        auto state = read_state(config_.state_file);
        for (const auto& problem : state.problems)
            spdlog::error("names: {}", problem);
        const std::size_t count = state.persistent.size();
        registry_.restore_persistent(std::move(state.persistent));
        if (count > 0)
            spdlog::info("names: restored {} persistent connections from {}", count, config_.state_file);
    }
    boost::system::error_code ec;
    auto address = asio::ip::make_address(config_.listen.host, ec);
    if (ec)
        return proto::Error{"name server address '" + config_.listen.host + "' is not an IP address"};
    asio::ip::tcp::endpoint tcp_endpoint(address, config_.listen.port);
    acceptor_.open(tcp_endpoint.protocol(), ec);
    if (!ec)
        acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
        acceptor_.bind(tcp_endpoint, ec);
    if (!ec)
        acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
        return proto::Error{"name server cannot listen on TCP " + config_.listen.text() + ": " +
                            ec.message()};
    const auto bound_port = acceptor_.local_endpoint().port();
    asio::ip::udp::endpoint udp_endpoint(address, bound_port);
    udp_.open(udp_endpoint.protocol(), ec);
    if (!ec)
        udp_.bind(udp_endpoint, ec);
    if (ec)
        return proto::Error{"name server cannot listen on UDP port " + std::to_string(bound_port) + ": " +
                            ec.message()};
    if (auto discovery = start_discovery(); !discovery)
        return discovery;
    asio::co_spawn(io_, accept_loop(), asio::detached);
    asio::co_spawn(io_, udp_loop(), asio::detached);
    spdlog::info("names: serving on {} (TCP and UDP)", endpoint().text());
    return proto::Ok{};
}

proto::Status NameServer::start_discovery() {
    if (!config_.discovery)
        return proto::Ok{};
    boost::system::error_code ec;
    const auto listen = asio::ip::make_address(config_.listen.host, ec);
    if (!ec && listen.is_loopback()) {
        spdlog::info("names: listening on loopback only: not answering discovery queries on {}",
                     config_.discovery->text());
        return proto::Ok{};
    }
    const auto group = asio::ip::make_address(config_.discovery->host, ec);
    if (ec || !group.is_v4() || !group.is_multicast())
        return proto::Error{"discovery group " + config_.discovery->text() +
                            " is not an IPv4 multicast address"};
    const asio::ip::udp::endpoint bound(group, config_.discovery->port);
    discovery_.open(bound.protocol(), ec);
    if (!ec)
        discovery_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
        discovery_.bind(bound, ec);  // bound to the group: only datagrams sent to it arrive
    if (!ec) {
        // On the interface of the listening address; any interface when it listens on all.
        if (listen.is_v4() && !listen.is_unspecified())
            discovery_.set_option(asio::ip::multicast::join_group(group.to_v4(), listen.to_v4()), ec);
        else
            discovery_.set_option(asio::ip::multicast::join_group(group), ec);
    }
    if (ec)
        return proto::Error{"cannot answer discovery on " + config_.discovery->text() + ": " + ec.message()};
    asio::co_spawn(io_, discovery_loop(), asio::detached);
    spdlog::info("names: answering discovery queries on {}", config_.discovery->text());
    return proto::Ok{};
}

Task<void> NameServer::discovery_loop() {
    std::vector<std::uint8_t> buffer(2048);
    while (!stopped_) {
        asio::ip::udp::endpoint from;
        auto [ec, n] = co_await discovery_.async_receive_from(asio::buffer(buffer), from, use_nothrow);
        if (ec) {
            if (stopped_ || ec == asio::error::operation_aborted)
                co_return;
            continue;
        }
        // Not a query: no answer, so a stray datagram cannot make us send anything.
        const auto request = parse_discovery_query({buffer.data(), n}, buffer.size());
        if (!request)
            continue;
        spdlog::debug("names: discovery query from {}", from.address().to_string());
        // With the secret, the answer proves it over the query's nonce (discovery.hpp).
        const auto query = proto::DiscoverRequest::decode(request->body);
        const auto answer =
            proto::discovery_reply(request->id, endpoint(), config_.secret ? &*config_.secret : nullptr,
                                   query ? query->nonce : std::string{});
        co_await discovery_.async_send_to(asio::buffer(answer), from, use_nothrow);
    }
}

void NameServer::stop() {
    if (stopped_)
        return;
    stopped_ = true;
    boost::system::error_code ignored;
    acceptor_.close(ignored);
    udp_.close(ignored);
    discovery_.close(ignored);
}

proto::Endpoint NameServer::endpoint() const {
    boost::system::error_code ec;
    auto local = acceptor_.local_endpoint(ec);
    return {config_.listen.host, ec ? config_.listen.port : local.port()};
}

Task<void> NameServer::accept_loop() {
    while (!stopped_) {
        auto [ec, socket] = co_await acceptor_.async_accept(use_nothrow);
        if (ec) {
            if (stopped_ || ec == asio::error::operation_aborted)
                co_return;
            spdlog::warn("names: accept failed: {}", ec.message());
            continue;
        }
        // A peer over its limits is closed at once, before anything is read from it.
        const auto remote = socket.remote_endpoint(ec);
        const std::string peer = "address " + (ec ? std::string("?") : remote.address().to_string());
        auto admission = peers_->admit(peer);
        if (!admission.ticket) {
            refused(peer, admission.refusal);
            continue;  // the socket closes here
        }
        socket.set_option(asio::ip::tcp::no_delay(true), ec);
        keep_alive(socket.native_handle());
        auto session = std::make_shared<NameSession>(Socket(std::move(socket)), *this, next_session_++);
        session->set_description("names session from " + peer.substr(8));
        session->count_against_peer(std::move(admission.ticket));
        session->require_secret(config_.secret);
        session->set_handshake_timeout(config_.handshake_timeout);
        session->start({proto::protocol_version, "names", ""});
    }
}

Task<void> NameServer::udp_loop() {
    // Largest UDP payload; a reply that does not fit says so (use TCP for big lists).
    constexpr std::size_t max_datagram = 65507;
    std::vector<std::uint8_t> buffer(max_datagram);
    while (!stopped_) {
        asio::ip::udp::endpoint from;
        auto [ec, n] = co_await udp_.async_receive_from(asio::buffer(buffer), from, use_nothrow);
        if (ec) {
            if (stopped_ || ec == asio::error::operation_aborted)
                co_return;
            continue;
        }
        const auto request = parse_datagram_request({buffer.data(), n}, max_datagram);
        proto::Bytes answer;
        if (!request) {
            answer = proto::make_error_frame(request.error().message);
        } else if (config_.secret) {
            // A datagram cannot prove it holds the secret: with one, look-ups are for TCP peers.
            answer = proto::encode_reply(proto::make_refusal(
                request->id, ReplyCode::refused, "this name server has a deployment secret: ask over TCP"));
        } else {
            answer = proto::encode_reply(this->answer(*request, 0));
            if (answer.size() > max_datagram) {
                answer = proto::encode_reply(proto::make_refusal(request->id, ReplyCode::refused,
                                                                 "answer too large for UDP; ask over TCP"));
            }
        }
        co_await udp_.async_send_to(asio::buffer(answer), from, use_nothrow);
    }
}

proto::Reply NameServer::answer(const proto::Request& request, std::uint64_t session,
                                const SessionAddresses& where, const proto::Subject* certified) {
    try {
        return handle(request, session, where, certified);
    } catch (const std::exception& e) {
        // A field of the wrong JSON type: refuse the request, keep the session and the server.
        return proto::make_refusal(request.id, ReplyCode::usage,
                                   std::string("malformed request: ") + e.what());
    }
}

void NameServer::session_closed(std::uint64_t session) {
    registry_.session_closed(session, Clock::now());
    auto timer = std::make_shared<asio::steady_timer>(io_, config_.grace);
    timer->async_wait([this, timer](boost::system::error_code) {
        if (stopped_)
            return;
        for (const auto& name : registry_.expire(Clock::now()))
            spdlog::info("names: port {} expired", name);
    });
}

void NameServer::save_state() {
    if (config_.state_file.empty())
        return;
    if (auto written = write_durably(config_.state_file, state_text(registry_.persistent())); !written)
        spdlog::error("names: cannot save the state file: {}", written.error().message);
}

}  // namespace plexus::daemon::names
