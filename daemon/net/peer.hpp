#pragma once
// Threading: one io_context thread.

#include <chrono>
#include <functional>
#include <map>
#include <memory>

#include <nlohmann/json.hpp>

#include "framed_connection.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/endpoint.hpp"

namespace plexus::daemon {

/// A connection this daemon opened: to the name server, to another daemon for a forwarded
/// request, or as the sending end of a tcp connection between ports (a link).
class Peer : public FramedConnection {
public:
    using Duration = std::chrono::steady_clock::duration;

    /// Connects to `endpoint`, exchanges hellos, and returns the started peer or why it failed.
    static Task<proto::Result<std::shared_ptr<Peer>>> connect(asio::any_io_executor executor,
                                                              proto::Endpoint endpoint, proto::Hello mine,
                                                              std::size_t max_frame, Duration timeout,
                                                              std::function<void()> on_space = {},
                                                              std::optional<proto::Secret> secret = {});

    Peer(Socket socket, std::size_t max_frame, std::function<void()> on_space, std::string description);

    /// Sends a request and waits for its reply; an Error if the peer closes or `timeout` passes.
    Task<proto::Result<proto::Reply>> request(nlohmann::json body, Duration timeout);

    /// Runs once when the connection closes, with the reason.
    std::function<void(const std::string&)> closed_handler;

protected:
    proto::Status on_hello(const proto::Hello& hello) override;
    Task<bool> on_frame(InFrame frame) override;
    void on_closed(const std::string& reason) override;

private:
    struct Pending;
    std::map<std::uint64_t, std::shared_ptr<Pending>> pending_;
    std::uint64_t next_id_ = 1;
    std::string closed_reason_;
};

}  // namespace plexus::daemon
