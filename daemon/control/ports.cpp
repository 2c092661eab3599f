// A client's own ports: `open`, `close`, and `shm` (a shared-memory region to write a port's
// large payloads into).
#include <spdlog/spdlog.h>

#include "control_plane.hpp"
#include "core/router.hpp"
#include "names/name_client.hpp"
#include "net/session.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

Task<proto::Reply> ControlPlane::open_port(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto& config = host_.config();
    const auto asked = proto::OpenRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string name = asked->port;
    if (auto allowed = permitted(session.get(), Action::open, name); !allowed)
        co_return refuse(allowed.error().message);
    const auto policy = parse_queue_policy(asked->policy);
    if (!policy)
        co_return refuse("queue policy must be 'strict' or 'latest'", proto::ReplyCode::usage);
    const std::size_t capacity = asked->capacity.value_or(config.default_capacity);
    auto opened = host_.router().open(name, session->id(), *policy, capacity, config.queue_bytes);
    if (!opened)
        co_return refuse(opened.error().message);
    auto port = *opened;
    // Its thread, before the name server hears of it: connections made from now on cross to it.
    port->set_shard(session->shard());
    port->served = asked->serve;
    auto registered = co_await host_.names().register_port(name);
    if (!registered || session->closed()) {
        host_.router().close(name);
        if (!registered)
            co_return refuse("cannot register " + name + ": " + registered.error().message);
        co_return refuse("the client went away while " + name + " was being registered");
    }
    const std::uint64_t handle = session->add_port(port);
    spdlog::info("port {} opened ({} queue of {}{})", name, queue_policy_name(*policy), capacity,
                 port->served ? ", answering calls" : "");
    // Restore remembered connections before answering, so the client's first write already
    // flows along them.
    co_await restore_persistent(std::move(*registered));
    co_return ok(proto::OpenReply{handle, config.node});
}

Task<proto::Reply> ControlPlane::close_port(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto asked = proto::CloseRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::uint64_t handle = asked->handle;
    auto port = session->take_port(handle);
    if (!port)
        co_return refuse("no open port with handle " + std::to_string(handle));
    host_.forget_port(port);
    co_return ok(proto::CloseReply{});
}

Task<proto::Reply> ControlPlane::report(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto asked = proto::ReportRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    auto port = session->port(asked->handle);
    if (!port)
        co_return refuse("no open port with handle " + std::to_string(asked->handle));
    port->reported = asked->counters;
    co_return ok(proto::ReportReply{});
}

Task<proto::Reply> ControlPlane::shm(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto& config = host_.config();
    if (config.shm_region_bytes == 0)
        co_return refuse("shared memory is off on this daemon (shm_region_bytes is 0)");
    if (!session->is_local())
        co_return refuse("shared memory needs a client on this machine (the Unix socket)");
    const auto asked = proto::ShmRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    session->enable_shm();
    if (!asked->handle)
        co_return ok(proto::ShmReply{});
    const std::uint64_t handle = *asked->handle;
    const std::uint64_t payload = asked->bytes;  // before any change
    if (!session->has_port(handle))
        co_return refuse("no open port with handle " + std::to_string(handle));
    if (const auto known = session->shm_region(handle))
        co_return ok(proto::ShmReply{known->id(), known->size()});
    // Room for a few of the payload the client is about to write, however large it is (up to the
    // frame limit, which the copy-out path needs), and never less than the configured size.
    constexpr std::size_t payloads_per_region = 4;
    constexpr std::size_t granule = 1024 * 1024;
    const std::size_t capped = std::min<std::uint64_t>(payload, config.max_frame);
    const std::size_t wanted = (capped * payloads_per_region + granule - 1) / granule * granule;
    const std::size_t size = std::max(config.shm_region_bytes, wanted);
    if (shm_usage_->bytes + size > config.shm_total_bytes) {
        co_return refuse("the daemon's shared memory is used up (shm_total_bytes " +
                         std::to_string(config.shm_total_bytes) + ")");
    }
    auto created = ShmRegion::create(next_region_++, size, session, shm_usage_);
    if (!created) {
        spdlog::warn("no shared-memory region for {}: {}", session->description(), created.error().message);
        co_return refuse("no shared-memory region: " + created.error().message);
    }
    const auto region = *created;
    // The region frame goes out before the reply, so the client has the region when it learns its id.
    session->add_shm_region(handle, region);
    co_return ok(proto::ShmReply{region->id(), region->size()});
}

}  // namespace plexus::daemon
