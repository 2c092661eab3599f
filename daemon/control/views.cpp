// `plexus stats` and `plexus events`: the views of inspect/ for a port of this daemon, or the
// request forwarded to the daemon that hosts the port.
#include "control_plane.hpp"
#include "core/router.hpp"
#include "inspect/events_view.hpp"
#include "inspect/node_view.hpp"
#include "inspect/stats_view.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

Task<proto::Reply> ControlPlane::stats(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::StatsRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string& port = asked->port;
    if (!port.empty() && !host_.router().find(port))
        co_return co_await forward(request, asked->forwarded, port);
    co_return ok(proto::StatsReply{inspect::stats_view(host_, *shm_usage_, port)});
}

Task<proto::Reply> ControlPlane::events(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::EventsRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string& name = asked->port;
    auto port = host_.router().find(name);
    if (!port)
        co_return co_await forward(request, asked->forwarded, name);
    co_return ok(proto::EventsReply{
        inspect::events_view(*port, asked->check, host_.config().node, host_.clock().now())});
}

Task<proto::Reply> ControlPlane::inspect(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::InspectRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    if (asked->only_arbitration)
        co_return ok(proto::InspectReply{inspect::arbitration_view(host_)});
    co_return ok(proto::InspectReply{inspect::node_view(host_, *shm_usage_)});
}

}  // namespace plexus::daemon
