// `plexus record`: recordings of this daemon's ports into files on its machine (docs/RECORDING.md).
// A recording lives while the session that started it does: a recorder whose client died (even by
// kill -9) is stopped within a sweep period, and its file closed.
#include <filesystem>

#include <spdlog/spdlog.h>

#include "control_plane.hpp"
#include "core/router.hpp"
#include "net/session.hpp"
#include "record/recorder.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

namespace {
using proto::ReplyCode;
/// How often recordings are looked at: a dead client's or an ended one is stopped within this.
constexpr auto sweep_period = std::chrono::milliseconds(250);
/// A recording asked for through another daemon ends when nobody asked about it for this long
/// (plexus record asks twice a second).
constexpr auto lease_period = std::chrono::seconds(5);
}  // namespace

ControlPlane::~ControlPlane() = default;

Task<proto::Reply> ControlPlane::record_start(std::shared_ptr<Session> session,
                                              const proto::Request& request) {
    const auto asked = proto::RecordStartRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    if (asked->path.empty() || !std::filesystem::path(asked->path).is_absolute())
        co_return refuse("record needs an absolute file path", ReplyCode::usage);
    std::vector<std::shared_ptr<Port>> ports;
    auto& router = host_.router();
    if (asked->all) {
        for (const auto& [name, port] : router.ports())
            ports.push_back(port);
        if (ports.empty())
            co_return refuse("node '" + host_.config().node + "' hosts no port to record");
    }
    // Each daemon records its own ports, into a file on its own machine: ports that all live on
    // another daemon are its to record (plexus record asks once per node).
    if (!asked->all && !asked->ports.empty() &&
        std::none_of(asked->ports.begin(), asked->ports.end(),
                     [&](const std::string& name) { return router.find(name) != nullptr; }))
        co_return co_await forward(request, asked->forwarded, asked->ports.front());
    for (const auto& name : asked->ports) {
        auto port = router.find(name);
        if (!port) {
            co_return refuse("port " + name + " is not on node '" + host_.config().node +
                             "': ask for the ports of each node apart (plexus record does)");
        }
        if (std::find(ports.begin(), ports.end(), port) == ports.end())
            ports.push_back(std::move(port));
    }
    if (ports.empty())
        co_return refuse("record needs at least one port, or --all", ReplyCode::usage);
    record::RecorderOptions options;
    options.path = asked->path;
    options.node = host_.config().node;
    options.max_bytes = asked->max_bytes;
    options.split_bytes = asked->split_bytes;
    auto started = record::Recorder::start(ports, host_.clock(), std::move(options));
    if (!started)
        co_return refuse("cannot record: " + started.error().message);
    const std::uint64_t id = next_recording_++;
    Recording recording{session, std::move(*started), false, std::nullopt};
    if (asked->forwarded) {
        // Asked by another daemon for its client: alive while that client keeps asking.
        recording.owner.reset();
        recording.lease = std::chrono::steady_clock::now();
    }
    recordings_.emplace(id, std::move(recording));
    if (recordings_.size() == 1)
        asio::co_spawn(executor_, sweep_recordings(alive_), asio::detached);
    proto::RecordStartReply answer;
    answer.id = id;
    for (const auto& port : ports)
        answer.ports.push_back(port->name());
    co_return ok(answer);
}

Task<proto::Reply> ControlPlane::record_status(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::RecordStatusRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    if (!asked->port.empty() && !host_.router().find(asked->port))
        co_return co_await forward(request, asked->forwarded, asked->port);
    auto found = recordings_.find(asked->id);
    if (found != recordings_.end() && found->second.lease)
        found->second.lease = std::chrono::steady_clock::now();
    if (found == recordings_.end())
        co_return refuse("no recording " + std::to_string(asked->id) + " on this daemon", ReplyCode::no);
    auto document = found->second.recorder->status();
    document["id"] = asked->id;
    document["ended"] = found->second.recorder->ended();
    co_return ok(proto::RecordStatusReply{std::move(document)});
}

Task<proto::Reply> ControlPlane::record_stop(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::RecordStopRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    if (!asked->port.empty() && !host_.router().find(asked->port))
        co_return co_await forward(request, asked->forwarded, asked->port);
    auto found = recordings_.find(asked->id);
    if (found == recordings_.end())
        co_return refuse("no recording " + std::to_string(asked->id) + " on this daemon", ReplyCode::no);
    found->second.recorder->stop("stopped by its client");
    found->second.stopped = true;
    // The recorder's thread writes what waits and closes the file; this waits for it without
    // holding the daemon's thread.
    asio::steady_timer timer(executor_);
    while (!found->second.recorder->finished()) {
        timer.expires_after(std::chrono::milliseconds(10));
        co_await timer.async_wait(asio::use_awaitable);
        found = recordings_.find(asked->id);
        if (found == recordings_.end())
            co_return refuse("the recording went away while stopping", ReplyCode::no);
    }
    auto document = found->second.recorder->status();
    document["id"] = asked->id;
    recordings_.erase(found);
    co_return ok(proto::RecordStatusReply{std::move(document)});
}

Task<void> ControlPlane::sweep_recordings(std::weak_ptr<void> alive) {
    asio::steady_timer timer(executor_);
    for (;;) {
        timer.expires_after(sweep_period);
        co_await timer.async_wait(asio::use_awaitable);
        if (alive.expired())
            co_return;  // the control plane is gone
        for (auto it = recordings_.begin(); it != recordings_.end();) {
            auto& recording = it->second;
            // A local client's recording ends with its session; another daemon's client's when
            // it stops asking how it goes.
            const bool orphan = recording.lease
                                    ? std::chrono::steady_clock::now() - *recording.lease > lease_period
                                    : recording.owner.expired();
            if (!recording.stopped && (orphan || recording.recorder->ended())) {
                recording.recorder->stop(orphan ? "its client went away" : "");
                recording.stopped = true;
                if (orphan)
                    spdlog::info("recording {}: its client went away; closing the file", it->first);
            }
            // An orphan's file is closed once its thread is done; nobody will ask for its status.
            if (orphan && recording.recorder->finished())
                it = recordings_.erase(it);
            else
                ++it;
        }
        if (recordings_.empty())
            co_return;  // the next record_start starts another sweep
    }
}

}  // namespace plexus::daemon
