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
    const std::string port = text(request.body, "port");
    if (!port.empty() && !host_.router().find(port))
        co_return co_await forward(request, port);
    co_return ok(inspect::stats_view(host_, *shm_usage_, port));
}

Task<proto::Reply> ControlPlane::events(std::shared_ptr<Session>, const proto::Request& request) {
    const std::string name = text(request.body, "port");
    auto port = host_.router().find(name);
    if (!port)
        co_return co_await forward(request, name);
    co_return ok(inspect::events_view(*port, request.body.value("check", false), host_.config().node,
                                      host_.clock().now()));
}

Task<proto::Reply> ControlPlane::inspect(std::shared_ptr<Session>, const proto::Request& request) {
    if (text(request.body, "only") == "arbitration")
        co_return ok(inspect::arbitration_view(host_));
    co_return ok(inspect::node_view(host_, *shm_usage_));
}

}  // namespace plexus::daemon
