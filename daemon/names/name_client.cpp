#include "name_client.hpp"

#include <spdlog/spdlog.h>

namespace plexus::daemon::names {

namespace {
constexpr auto request_timeout = std::chrono::seconds(5);
constexpr auto first_retry = std::chrono::milliseconds(100);
constexpr auto longest_retry = std::chrono::seconds(2);
constexpr auto reconnect_patience = std::chrono::seconds(3);
}  // namespace

NameClient::NameClient(asio::io_context& io, proto::Endpoint names, std::string node, std::string address,
                       std::size_t max_frame)
    : io_(io),
      names_(std::move(names)),
      node_(std::move(node)),
      address_(std::move(address)),
      max_frame_(max_frame),
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
    while (!connected() && !stopped_) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline)
            break;
        co_await state_changed_.wait_for(deadline - now);
    }
    co_return connected();
}

Task<proto::Result<proto::Reply>> NameClient::request(nlohmann::json body) {
    using Outcome = proto::Result<proto::Reply>;
    // Just started, or the name server just restarted: give the reconnect loop a moment.
    if (!connected())
        co_await wait_connected(reconnect_patience);
    if (!connected()) {
        co_return Outcome(
            proto::Error{"the name server at " + names_.text() +
                         " is not reachable (start plexus-names, or plexusd --embedded-names)"});
    }
    auto peer = peer_;
    co_return co_await peer->request(std::move(body), request_timeout);
}

Task<void> NameClient::run() {
    auto delay = std::chrono::steady_clock::duration(first_retry);
    bool warned = false;
    while (!stopped_) {
        proto::Hello hello_out;
        hello_out.role = std::string("daemon");
        hello_out.node = node_;
        auto connected_peer =
            co_await Peer::connect(io_.get_executor(), names_, hello_out, max_frame_, request_timeout);
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
        nlohmann::json body1 = {{"op", "register_node"}, {"node", node_}, {"address", address_}};
        auto hello = co_await peer->request(body1, request_timeout);
        if (!hello || hello->code != proto::ReplyCode::ok) {
            std::string why = hello.ok() ? std::string("refused") : hello.error().message;
            if (hello.ok() && hello->body.contains("error"))
                why = hello->body["error"].get<std::string>();
            spdlog::error("name server refused this daemon: {}", why);
            peer->close("refused");
            asio::steady_timer timer(io_, longest_retry);
            co_await timer.async_wait(use_nothrow);
            continue;
        }
        std::vector<std::string> ports;
        if (ports_to_register)
            ports = ports_to_register();
        for (const auto& port : ports) {
            nlohmann::json body2 = {{"op", "register_port"}, {"port", port}};
            auto reply = co_await peer->request(body2, request_timeout);
            if (!reply || reply->code != proto::ReplyCode::ok) {
                spdlog::error("name server: cannot register {} again: {}", port,
                              reply ? reply->body.dump() : reply.error().message);
            } else if (on_persistent) {
                on_persistent(reply->body.value("persistent", nlohmann::json::array()));
            }
        }
        peer_ = peer;
        registered_ = true;
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
