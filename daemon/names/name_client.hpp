#pragma once
// Threading: one io_context thread.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "../net/peer.hpp"
#include "../net/signal.hpp"

namespace plexus::daemon::names {

/// The daemon's link to the name server. Keeps reconnecting with back-off; on every (re)connect it
/// registers the node and all its ports again, so a restarted name server recovers by itself.
class NameClient {
public:
    NameClient(asio::io_context& io, proto::Endpoint names, std::string node, std::string address,
               std::size_t max_frame);

    void start();
    void stop();
    bool connected() const { return peer_ && !peer_->closed() && registered_; }
    /// Waits up to `timeout` for the first successful registration.
    Task<bool> wait_connected(std::chrono::steady_clock::duration timeout);
    /// Sends a request; an Error when the name server cannot be reached.
    Task<proto::Result<proto::Reply>> request(nlohmann::json body);
    const proto::Endpoint& endpoint() const { return names_; }

    /// Lists the ports to register again after a reconnect.
    std::function<std::vector<std::string>()> ports_to_register;
    /// Receives the persistent connections the name server knows for a port just registered.
    std::function<void(const nlohmann::json& persistent)> on_persistent;

private:
    Task<void> run();

    asio::io_context& io_;
    proto::Endpoint names_;
    std::string node_;
    std::string address_;
    std::size_t max_frame_;
    std::shared_ptr<Peer> peer_;
    Signal state_changed_;
    bool registered_ = false;
    bool stopped_ = false;
};

}  // namespace plexus::daemon::names
