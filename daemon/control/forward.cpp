// Questions about this daemon (`ping`, `node`), questions for the name server (`lookup`, `list`),
// and requests about a port that lives on another daemon, forwarded to it.
#include "control_plane.hpp"
#include "core/router.hpp"
#include "names/name_client.hpp"
#include "net/peer.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

Task<proto::Reply> ControlPlane::ping(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::PingRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string& port = asked->port;
    if (port.empty() || host_.router().find(port))
        co_return ok(proto::PingReply{host_.config().node, host_.address()});
    co_return co_await forward(request, asked->forwarded, port);
}

Task<proto::Reply> ControlPlane::node(std::shared_ptr<Session>, const proto::Request& request) {
    if (const auto asked = proto::NodeRequest::decode(request.body); !asked)
        co_return malformed(asked.error());
    const auto& config = host_.config();
    co_return ok(proto::NodeReply{config.node, host_.address(), config.names.text(), host_.http_address(),
                                  host_.http_tls(), host_.http_fingerprint()});
}

// Only the fields the name server reads are passed on: a client cannot reach the name server
// through the daemon with anything else.
Task<proto::Reply> ControlPlane::lookup(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::LookupRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    nlohmann::json question = asked->encode();
    co_return relay(co_await host_.names().request(std::move(question)));
}

Task<proto::Reply> ControlPlane::list(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::ListRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    nlohmann::json question = asked->encode();
    co_return relay(co_await host_.names().request(std::move(question)));
}

Task<proto::Reply> ControlPlane::forward(const proto::Request& request, bool forwarded,
                                         const std::string& port) {
    if (forwarded)
        co_return refuse("port " + port + " is not on node '" + host_.config().node + "'");
    auto found = co_await host_.names().lookup(port);
    if (!found)
        co_return refuse(found.error().message);
    const std::string where = found->address;
    auto endpoint = proto::parse_endpoint(where);
    if (!endpoint)
        co_return refuse("the name server gave a bad address for " + port + ": " + where);
    const proto::Hello hello = our_hello("daemon");
    const std::function<void()> no_space;
    const auto secret = host_.config().secret;
    auto peer = co_await Peer::connect(executor_, *endpoint, hello, host_.config().max_frame, peer_timeout,
                                       no_space, secret);
    if (!peer)
        co_return refuse("cannot reach the daemon of " + port + ": " + peer.error().message);
    auto body = request.body;
    body["forwarded"] = true;
    auto reply = co_await (*peer)->request(body, peer_timeout);
    (*peer)->close_when_drained();
    co_return relay(reply);
}

}  // namespace plexus::daemon
