#include "name_client.hpp"

#include <spdlog/spdlog.h>

#include "plexus/proto/name_operations.hpp"

namespace plexus::daemon::names {

namespace {
constexpr auto request_timeout = std::chrono::seconds(5);
constexpr auto first_retry = std::chrono::milliseconds(100);
constexpr auto longest_retry = std::chrono::seconds(2);
constexpr auto reconnect_patience = std::chrono::seconds(3);

/// The remembered connections of a register_port answer.
proto::Result<std::vector<ConnectionEntry>> persistent_of(const nlohmann::json& answer) {
    auto decoded = proto::RegisterPortReply::decode(answer);
    if (!decoded)
        return decoded.error();
    std::vector<ConnectionEntry> entries;
    for (auto& c : decoded->persistent)
        entries.push_back({std::move(c.source), std::move(c.destination), std::move(c.carrier), true});
    return entries;
}

// GCC 12 miscompiles braced temporaries inside co_await expressions: built here instead.
nlohmann::json register_port_body(const std::string& port) {
    return proto::RegisterPortRequest{port}.encode();
}

nlohmann::json add_connection_body(const ConnectionEntry& connection) {
    return proto::AddConnectionRequest{connection.source, connection.destination, connection.carrier,
                                       connection.persistent}
        .encode();
}
}  // namespace

nlohmann::json NameClient::register_node_body() const {
    return proto::RegisterNodeRequest{node_, address_}.encode();
}

NameClient::NameClient(asio::io_context& io, proto::Endpoint names, std::string node, std::string address,
                       std::size_t max_frame, std::optional<proto::Secret> secret)
    : io_(io),
      names_(std::move(names)),
      node_(std::move(node)),
      address_(std::move(address)),
      max_frame_(max_frame),
      secret_(std::move(secret)),
      state_changed_(io.get_executor()) {}

void NameClient::start() {
    asio::co_spawn(io_, run(), asio::detached);
}

void NameClient::stop() {
    stopped_ = true;
    if (peer_)
        peer_->close("daemon stopping");
    state_changed_.notify();
}

Task<bool> NameClient::wait_connected(std::chrono::steady_clock::duration timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!connected() && !stopped_ && !refusal_) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline)
            break;
        co_await state_changed_.wait_for(deadline - now);
    }
    co_return connected();
}

Task<proto::Result<proto::Reply>> NameClient::request(nlohmann::json body) {
    co_return co_await request(std::move(body), request_timeout);
}

Task<proto::Result<proto::Reply>> NameClient::request(nlohmann::json body,
                                                      std::chrono::steady_clock::duration timeout) {
    using Outcome = proto::Result<proto::Reply>;
    // Just started, or the name server just restarted: give the reconnect loop a moment.
    if (!connected() && !refusal_)
        co_await wait_connected(std::min<std::chrono::steady_clock::duration>(reconnect_patience, timeout));
    if (refusal_) {
        co_return Outcome(
            proto::Error{"the name server at " + names_.text() + " refuses this daemon: " + *refusal_});
    }
    if (!connected()) {
        co_return Outcome(
            proto::Error{"the name server at " + names_.text() +
                         " is not reachable (start plexus-names, or plexusd --embedded-names)"});
    }
    auto peer = peer_;
    co_return co_await peer->request(std::move(body), timeout);
}

Task<proto::Result<proto::Reply>> NameClient::ask(nlohmann::json body) {
    using Outcome = proto::Result<proto::Reply>;
    const std::string what = body.value("op", std::string{});
    auto reply = co_await request(std::move(body));
    if (!reply)
        co_return reply;
    if (reply->code != proto::ReplyCode::ok)
        co_return Outcome(proto::Error{reply->body.value("error", "the name server refused " + what)});
    co_return reply;
}

Task<proto::Result<std::vector<ConnectionEntry>>> NameClient::register_port(std::string port) {
    using Outcome = proto::Result<std::vector<ConnectionEntry>>;
    nlohmann::json body = register_port_body(port);
    auto reply = co_await ask(std::move(body));
    if (!reply)
        co_return Outcome(reply.error());
    co_return persistent_of(reply->body);
}

Task<proto::Status> NameClient::unregister_port(std::string port) {
    co_return co_await unregister_port(std::move(port), request_timeout);
}

Task<proto::Status> NameClient::unregister_port(std::string port,
                                                std::chrono::steady_clock::duration timeout) {
    nlohmann::json body = proto::UnregisterPortRequest{port}.encode();
    auto reply = co_await request(std::move(body), timeout);
    if (!reply)
        co_return proto::Status(reply.error());
    if (reply->code != proto::ReplyCode::ok)
        co_return proto::Status(
            proto::Error{reply->body.value("error", "the name server refused unregister")});
    co_return proto::Status(proto::Ok{});
}

Task<proto::Result<PortEntry>> NameClient::lookup(std::string port) {
    using Outcome = proto::Result<PortEntry>;
    nlohmann::json body = proto::LookupRequest{port}.encode();
    auto reply = co_await request(std::move(body));
    if (!reply)
        co_return Outcome(reply.error());
    if (reply->code != proto::ReplyCode::ok)
        co_return Outcome(proto::Error{"port " + port + " does not exist"});
    auto found = proto::LookupReply::decode(reply->body);
    if (!found)
        co_return Outcome(found.error());
    co_return PortEntry{port, std::move(found->node), std::move(found->address)};
}

Task<proto::Result<std::string>> NameClient::mcast_group(std::string port) {
    using Outcome = proto::Result<std::string>;
    nlohmann::json body = proto::McastGroupRequest{port}.encode();
    auto reply = co_await ask(std::move(body));
    if (!reply)
        co_return Outcome(reply.error());
    auto given = proto::McastGroupReply::decode(reply->body);
    if (!given)
        co_return Outcome(given.error());
    co_return Outcome(std::move(given->group));
}

Task<proto::Status> NameClient::add_connection(ConnectionEntry connection) {
    nlohmann::json body = add_connection_body(connection);
    auto reply = co_await ask(std::move(body));
    co_return reply ? proto::Status(proto::Ok{}) : proto::Status(reply.error());
}

Task<proto::Status> NameClient::remove_connection(std::string source, std::string destination, bool forget) {
    nlohmann::json body = proto::RemoveConnectionRequest{source, destination, forget}.encode();
    auto reply = co_await ask(std::move(body));
    co_return reply ? proto::Status(proto::Ok{}) : proto::Status(reply.error());
}

void NameClient::notify_port_closed(std::string port, std::vector<ConnectionEntry> connections_removed) {
    asio::co_spawn(io_, tell_port_closed(std::move(port), std::move(connections_removed)), asio::detached);
}

void NameClient::notify_connection_down(std::string source, std::string destination) {
    asio::co_spawn(io_, tell_connection_down(std::move(source), std::move(destination)), asio::detached);
}

Task<void> NameClient::tell_port_closed(std::string port, std::vector<ConnectionEntry> connections_removed) {
    for (const auto& c : connections_removed)
        co_await remove_connection(c.source, c.destination, false);
    co_await unregister_port(port);
}

Task<void> NameClient::tell_connection_down(std::string source, std::string destination) {
    co_await remove_connection(std::move(source), std::move(destination), false);
}

Task<void> NameClient::run() {
    auto delay = std::chrono::steady_clock::duration(first_retry);
    bool warned = false;
    while (!stopped_) {
        const std::function<void()> no_space;
        proto::Hello hello_out;
        hello_out.role = std::string("daemon");
        hello_out.node = node_;
        auto connected_peer = co_await Peer::connect(io_.get_executor(), names_, hello_out, max_frame_,
                                                     request_timeout, no_space, secret_);
        if (stopped_)
            co_return;
        if (!connected_peer) {
            if (!warned)
                spdlog::warn("name server: {}; retrying", connected_peer.error().message);
            warned = true;
            asio::steady_timer timer(io_, delay);
            co_await timer.async_wait(use_nothrow);
            delay = std::min<std::chrono::steady_clock::duration>(delay * 2, longest_retry);
            continue;
        }
        auto peer = *connected_peer;
        peer->set_description("name server " + names_.text());
        // With identities the name server shows a name server's certificate: a node's, even a
        // valid one, could be a compromised machine answering in the name server's place.
        if (secret_ && secret_->identity() &&
            (!peer->peer_subject() || peer->peer_subject()->kind != proto::Subject::Kind::names)) {
            const std::string shown =
                peer->peer_subject() ? peer->peer_subject()->text() : "no Plexus certificate";
            const std::string why = "the name server at " + names_.text() + " shows the certificate of " +
                                    shown + ", not a name server's";
            if (!refusal_ || *refusal_ != why)
                spdlog::error("{}", why);
            refusal_ = why;
            state_changed_.notify();
            peer->close("not a name server");
            asio::steady_timer timer(io_, longest_retry);
            co_await timer.async_wait(use_nothrow);
            continue;
        }
        auto hello = co_await peer->request(register_node_body(), request_timeout);
        if (!hello || hello->code != proto::ReplyCode::ok) {
            std::string why = hello.ok() ? std::string("refused") : hello.error().message;
            if (hello.ok() && hello->body.contains("error"))
                why = hello->body["error"].get<std::string>();
            if (!refusal_ || *refusal_ != why)
                spdlog::error("name server refused this daemon: {}", why);
            refusal_ = why;
            state_changed_.notify();
            peer->close("refused");
            if (on_refused)
                on_refused(why, ever_registered_);
            if (stopped_)
                co_return;
            asio::steady_timer timer(io_, longest_retry);
            co_await timer.async_wait(use_nothrow);
            continue;
        }
        std::vector<std::string> ports;
        if (ports_to_register)
            ports = ports_to_register();
        for (const auto& port : ports) {
            auto reply = co_await peer->request(register_port_body(port), request_timeout);
            if (!reply || reply->code != proto::ReplyCode::ok) {
                spdlog::error("name server: cannot register {} again: {}", port,
                              reply ? reply->body.dump() : reply.error().message);
            } else if (on_persistent) {
                auto persistent = persistent_of(reply->body);
                if (persistent)
                    on_persistent(std::move(*persistent));
                else
                    spdlog::error("name server: {}", persistent.error().message);
            }
        }
        std::vector<ConnectionEntry> connections;
        if (connections_to_register)
            connections = connections_to_register();
        for (const auto& connection : connections) {
            auto reply = co_await peer->request(add_connection_body(connection), request_timeout);
            if (!reply || reply->code != proto::ReplyCode::ok) {
                spdlog::error("name server: cannot register {} -> {} again: {}", connection.source,
                              connection.destination, reply ? reply->body.dump() : reply.error().message);
            }
        }
        peer_ = peer;
        registered_ = true;
        ever_registered_ = true;
        if (refusal_) {
            spdlog::info("the name server accepts this daemon again");
            refusal_.reset();
        }
        warned = false;
        delay = first_retry;
        spdlog::info("registered node '{}' ({}) with the name server at {}", node_, address_, names_.text());
        state_changed_.notify();
        Signal closed(io_.get_executor());
        peer->closed_handler = [&closed](const std::string&) { closed.notify(); };
        while (!peer->closed())
            co_await closed.wait();
        peer->closed_handler = nullptr;
        registered_ = false;
        state_changed_.notify();
        if (!stopped_)
            spdlog::warn("lost the name server at {}; reconnecting", names_.text());
    }
}

}  // namespace plexus::daemon::names
