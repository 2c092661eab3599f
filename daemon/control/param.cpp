// `plexus param get|set SRC DST`: the daemon of SRC answers for the send-side monitors and asks
// the daemon of DST for the recv-side ones (itself, when the connection is local).
#include <spdlog/spdlog.h>

#include "control_plane.hpp"
#include "core/inlet.hpp"
#include "core/router.hpp"
#include "monitor/stage.hpp"
#include "net/udp_carrier.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

namespace {

using proto::ReplyCode;

/// Runs get or set on every monitor of a chain and appends {script, side, param} per monitor.
/// On the monitors' worker (see apply_on_worker).
proto::Status apply(const monitor::MonitorChain& chain, const nlohmann::json& body, nlohmann::json& results,
                    bool& any_setparam) {
    const bool set = text(body, "action") == "set";
    for (const auto& monitor : chain.monitors) {
        if (set) {
            auto called = monitor->setparam(body.value("values", nlohmann::json::object()));
            if (!called)
                return called.error();
            any_setparam = any_setparam || *called;
        }
        auto param = monitor->getparam();
        if (!param)
            return param.error();
        auto stats = monitor->stats();
        results.push_back({{"script", stats["script"]}, {"side", stats["side"]}, {"param", *param}});
    }
    return proto::Ok{};
}

/// apply() where the monitors run: their scripts are theirs only, and a slow getparam delays only
/// this request.
Task<proto::Status> apply_on_worker(const std::shared_ptr<MessageFilter>& monitors,
                                    const nlohmann::json& body, nlohmann::json& results, bool& any_setparam) {
    auto* stage = monitor::stage_of(monitors);
    if (!stage)
        co_return proto::Ok{};
    proto::Status status = proto::Error{"the monitors of this connection are gone"};
    const std::function<void()> work = [&] { status = apply(stage->chain(), body, results, any_setparam); };
    co_await stage->run(work);
    co_return status;
}

proto::Reply answer(const nlohmann::json& results, bool any_setparam, const nlohmann::json& body) {
    return {0,
            ReplyCode::ok,
            {{"monitors", results}, {"any_setparam", any_setparam}, {"action", text(body, "action")}}};
}

}  // namespace

Task<proto::Reply> ControlPlane::param(std::shared_ptr<Session>, const proto::Request& request) {
    const std::string source = text(request.body, "source");
    const std::string destination = text(request.body, "destination");
    const std::string action = text(request.body, "action");
    if (action != "get" && action != "set")
        co_return proto::make_refusal(0, ReplyCode::usage, "param action must be get or set");
    auto port = host_.router().find(source);
    if (!port)
        co_return co_await forward(request, source);
    std::shared_ptr<Connection> connection;
    for (const auto& c : port->outgoing) {
        if (c->destination == destination)
            connection = c;
    }
    if (!connection)
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "ports " + source + " and " + destination + " are not connected");
    nlohmann::json results = nlohmann::json::array();
    bool any_setparam = false;
    // An mcast connection's send-side monitors are its port's, shared by all its mcast connections.
    std::shared_ptr<MessageFilter> send_side = connection->send_monitors;
    if (const auto* mcast = dynamic_cast<const McastLink*>(connection->sink.get()))
        send_side = mcast->sender().send_stage();
    auto applied = co_await apply_on_worker(send_side, request.body, results, any_setparam);
    if (!applied)
        co_return proto::make_refusal(0, ReplyCode::refused, applied.error().message);
    if (!connection->remote) {
        auto* inlet = static_cast<Inlet*>(connection->sink.get());
        auto inlet_applied = co_await apply_on_worker(inlet->monitors, request.body, results, any_setparam);
        if (!inlet_applied)
            co_return proto::make_refusal(0, ReplyCode::refused, inlet_applied.error().message);
    } else {
        proto::Request recv_half;
        recv_half.body = request.body;
        recv_half.body["op"] = "param_recv";
        recv_half.body.erase("forwarded");
        auto reply = co_await forward(recv_half, destination);
        if (reply.code != ReplyCode::ok)
            co_return reply;
        for (const auto& entry : reply.body.value("monitors", nlohmann::json::array()))
            results.push_back(entry);
        any_setparam = any_setparam || reply.body.value("any_setparam", false);
    }
    if (action == "set" && !any_setparam) {
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "no monitor on " + source + " -> " + destination + " has setparam");
    }
    co_return answer(results, any_setparam, request.body);
}

Task<proto::Reply> ControlPlane::param_recv(std::shared_ptr<Session>, const proto::Request& request) {
    const std::string source = text(request.body, "source");
    const std::string destination = text(request.body, "destination");
    auto port = host_.router().find(destination);
    if (!port)
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "port " + destination + " is not on this daemon");
    nlohmann::json results = nlohmann::json::array();
    bool any_setparam = false;
    // The inlets are gathered first: a connection made or removed while a worker applies the
    // parameters changes port->inbound, which a loop over it across the co_await would not survive.
    std::vector<std::shared_ptr<Inlet>> inlets;
    for (const auto& weak : port->inbound) {
        if (auto inlet = weak.lock(); inlet && inlet->source() == source)
            inlets.push_back(std::move(inlet));
    }
    for (const auto& inlet : inlets) {
        auto applied = co_await apply_on_worker(inlet->monitors, request.body, results, any_setparam);
        if (!applied)
            co_return proto::make_refusal(0, ReplyCode::refused, applied.error().message);
    }
    co_return answer(results, any_setparam, request.body);
}

}  // namespace plexus::daemon
