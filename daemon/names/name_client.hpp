#pragma once
// Threading: one io_context thread.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "../net/peer.hpp"
#include "../net/signal.hpp"
#include "name_protocol.hpp"

namespace plexus::daemon::names {

/// The daemon's link to the name server. Keeps reconnecting with back-off; on every (re)connect it
/// registers the node, all its ports and the connections out of them again, so a restarted name
/// server recovers by itself.
class NameClient {
public:
    NameClient(asio::io_context& io, proto::Endpoint names, std::string node, std::string address,
               std::size_t max_frame, std::optional<proto::Secret> secret = {});

    void start();
    void stop();
    bool connected() const { return peer_ && !peer_->closed() && registered_; }
    /// Waits up to `timeout` for the first successful registration.
    Task<bool> wait_connected(std::chrono::steady_clock::duration timeout);
    /// Sends a request; an Error when the name server cannot be reached.
    Task<proto::Result<proto::Reply>> request(nlohmann::json body);
    /// The same with a reply time limit of its own (shutdown has less than the usual 5 s).
    Task<proto::Result<proto::Reply>> request(nlohmann::json body,
                                              std::chrono::steady_clock::duration timeout);

    // Typed calls. Each answers an Error with the name server's reason when it refuses.
    /// Registers a port of this node; answers the persistent connections that name it.
    Task<proto::Result<std::vector<ConnectionEntry>>> register_port(std::string port);
    Task<proto::Status> unregister_port(std::string port);
    Task<proto::Status> unregister_port(std::string port, std::chrono::steady_clock::duration timeout);
    /// Where a port lives; an Error "port X does not exist" when it is not registered.
    Task<proto::Result<PortEntry>> lookup(std::string port);
    Task<proto::Status> add_connection(ConnectionEntry connection);
    /// The multicast group ("A.B.C.D:PORT") the name server gives `port`.
    Task<proto::Result<std::string>> mcast_group(std::string port);
    /// `forget`: also forget a persistent connection (a disconnect), not only mark it down.
    Task<proto::Status> remove_connection(std::string source, std::string destination, bool forget);

    // Fire and forget: for callers that must not wait (a port closing, a link going down). The
    // name server also drops a gone node's ports after its grace period if these never arrive.
    void notify_port_closed(std::string port, std::vector<ConnectionEntry> connections_removed);
    void notify_connection_down(std::string source, std::string destination);
    const proto::Endpoint& endpoint() const { return names_; }

    /// Lists the ports to register again after a reconnect.
    std::function<std::vector<std::string>()> ports_to_register;
    /// Lists the connections out of this node's ports, to register again after a reconnect (a name
    /// server restarted without its state file knows none of them).
    std::function<std::vector<ConnectionEntry>()> connections_to_register;
    /// Told when the name server refuses this node (its name is taken by a running daemon):
    /// `ever_registered` is false when it was refused before it ever registered (at start).
    std::function<void(const std::string& why, bool ever_registered)> on_refused;
    /// Receives the persistent connections the name server knows for a port just registered.
    std::function<void(std::vector<ConnectionEntry> persistent)> on_persistent;

private:
    Task<void> run();
    /// The request's reply if it was ok, else an Error with the refusal's reason.
    Task<proto::Result<proto::Reply>> ask(nlohmann::json body);
    nlohmann::json register_node_body() const;
    Task<void> tell_port_closed(std::string port, std::vector<ConnectionEntry> connections_removed);
    Task<void> tell_connection_down(std::string source, std::string destination);

    asio::io_context& io_;
    proto::Endpoint names_;
    std::string node_;
    std::string address_;
    std::size_t max_frame_;
    std::optional<proto::Secret> secret_;
    std::shared_ptr<Peer> peer_;
    Signal state_changed_;
    bool registered_ = false;
    bool ever_registered_ = false;
    bool stopped_ = false;
    /// Why the name server refused this node, while it does: requests fail at once with it.
    std::optional<std::string> refusal_;
};

}  // namespace plexus::daemon::names
