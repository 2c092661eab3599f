// `plexus param get|set SRC DST`: the daemon of SRC answers for the send-side monitors and asks
// the daemon of DST for the recv-side ones (itself, when the connection is local).
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "arbitration/carrier_rules.hpp"
#include "control_plane.hpp"
#include "core/inlet.hpp"
#include "core/router.hpp"
#include "monitor/stage.hpp"
#include "names/name_client.hpp"
#include "plexus/proto/carrier.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

namespace {

using proto::ReplyCode;

/// Places in a side's monitor chain (0 the first) of the monitors that took a `param set`.
using Takers = std::vector<std::size_t>;

/// Runs get or set on every monitor of a chain and appends {script, side, param} per monitor, and
/// the places of those that have a setparam to `took`. On the monitors' worker (see apply_on_worker).
proto::Status apply(const monitor::MonitorChain& chain, const proto::ParamArguments& asked,
                    std::vector<proto::MonitorParams>& results, bool& any_setparam, Takers& took) {
    const bool set = asked.action == "set";
    const nlohmann::json values = asked.values.is_null() ? nlohmann::json::object() : asked.values;
    for (std::size_t place = 0; place < chain.monitors.size(); ++place) {
        const auto& monitor = chain.monitors[place];
        if (set) {
            auto called = monitor->setparam(values);
            if (!called)
                return called.error();
            any_setparam = any_setparam || *called;
            if (*called)
                took.push_back(place);
        }
        auto param = monitor->getparam();
        if (!param)
            return param.error();
        auto stats = monitor->stats();
        results.push_back({stats.value("script", std::string{}), stats.value("side", std::string{}), *param});
    }
    return proto::Ok{};
}

/// apply() where the monitors run: their scripts are theirs only, and a slow getparam delays only
/// this request.
Task<proto::Status> apply_on_worker(const std::shared_ptr<MessageFilter>& monitors,
                                    const proto::ParamArguments& asked,
                                    std::vector<proto::MonitorParams>& results, bool& any_setparam,
                                    Takers& took) {
    auto* stage = monitor::stage_of(monitors);
    if (!stage)
        co_return proto::Ok{};
    proto::Status status = proto::Error{"the monitors of this connection are gone"};
    const std::function<void()> work = [&] {
        status = apply(stage->chain(), asked, results, any_setparam, took);
    };
    co_await stage->run(work);
    co_return status;
}

/// The monitor's own keys of a portmonitor clause (monitor/carrier_monitors.cpp's spec_of_clause): not
/// options that create(options) sees, so a value given to setparam under one of these names is not theirs.
bool monitor_own_key(const std::string& key) {
    for (const char* own : {"type", "file", "constraint", "aux", "onerror"}) {
        if (key == own)
            return true;
    }
    return false;
}

/// The clauses a monitor chain is built from, in the same order (ScriptHost::build_chain).
bool runs_monitor(const proto::Clause& clause) {
    return clause.modifier == "portmonitor" && !arbitration::arbitration_only(clause);
}

bool same_params(const proto::Clause& a, const proto::Clause& b) {
    return std::equal(a.params.begin(), a.params.end(), b.params.begin(), b.params.end(),
                      [](const proto::CarrierParam& x, const proto::CarrierParam& y) {
                          return x.key == y.key && x.value == y.value;
                      });
}

/// `carrier_text` with `values` written into the clauses whose monitors took them: a key's value
/// replaced where it stands, or the key added at the end of the clause. So the text `stats` and
/// `list` show says what the monitors run with, and a connection made again from it (a persistent
/// one, a link that comes back) starts with it. A key or value the grammar cannot hold -- a '+' in
/// the value, a dot in the key -- keeps its old text: the carrier must still read back the same.
std::string with_values(const std::string& carrier_text, const Takers& send_took, const Takers& recv_took,
                        const nlohmann::json& values) {
    auto parsed = proto::parse_carrier(carrier_text);
    if (!parsed || !values.is_object())
        return carrier_text;
    proto::Carrier carrier = std::move(*parsed);
    std::size_t send_place = 0;
    std::size_t recv_place = 0;
    // By index, not by reference: writing a value replaces `carrier`, clauses and all.
    for (std::size_t c = 0; c < carrier.clauses.size(); ++c) {
        if (!runs_monitor(carrier.clauses[c]))
            continue;
        const bool send = carrier.clauses[c].side == proto::Side::send;
        const std::size_t place = send ? send_place++ : recv_place++;
        const Takers& took = send ? send_took : recv_took;
        if (std::find(took.begin(), took.end(), place) == took.end())
            continue;
        for (const auto& [key, value] : values.items()) {
            if (monitor_own_key(key))
                continue;
            proto::Carrier candidate = carrier;
            auto& params = candidate.clauses[c].params;
            const std::string value_text = value.is_string() ? value.get<std::string>() : value.dump();
            auto it = std::find_if(params.begin(), params.end(),
                                   [&](const proto::CarrierParam& p) { return p.key == key; });
            if (it != params.end())
                it->value = value_text;
            else
                params.push_back({key, value_text});
            auto again = proto::parse_carrier(candidate.text());
            if (again && again->clauses.size() == candidate.clauses.size() &&
                same_params(again->clauses[c], candidate.clauses[c]))
                carrier = std::move(candidate);
        }
    }
    return carrier.text();
}

proto::Reply answer(std::vector<proto::MonitorParams> results, bool any_setparam, const std::string& action,
                    const Takers& took = {}) {
    proto::ParamReply reply;
    reply.monitors = std::move(results);
    reply.any_setparam = any_setparam;
    reply.action = action;
    reply.took.assign(took.begin(), took.end());
    return ok(reply);
}

}  // namespace

Task<proto::Reply> ControlPlane::param(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto decoded = proto::ParamRequest::decode(request.body);
    if (!decoded)
        co_return malformed(decoded.error());
    const proto::ParamRequest& asked = *decoded;
    const std::string& source = asked.source;
    const std::string& destination = asked.destination;
    const std::string& action = asked.action;
    if (action != "get" && action != "set")
        co_return proto::make_refusal(0, ReplyCode::usage, "param action must be get or set");
    if (action == "set") {  // changing what a connection's monitors do is attaching them anew
        if (auto allowed = permitted(session.get(), Action::monitor, source); !allowed)
            co_return proto::make_refusal(0, ReplyCode::refused, allowed.error().message);
    }
    auto port = host_.router().find(source);
    if (!port)
        co_return co_await forward(request, asked.forwarded, source);
    std::shared_ptr<Connection> connection;
    for (const auto& c : port->outgoing) {
        if (c->destination == destination)
            connection = c;
    }
    if (!connection)
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "ports " + source + " and " + destination + " are not connected");
    std::vector<proto::MonitorParams> results;
    bool any_setparam = false;
    Takers send_took;
    Takers recv_took;
    // An mcast connection's send-side monitors are its port's, shared by all its mcast connections.
    std::shared_ptr<MessageFilter> send_side = connection->send_monitors;
    if (auto shared = connection->sink->shared_send_stage())
        send_side = std::move(shared);
    auto applied = co_await apply_on_worker(send_side, asked, results, any_setparam, send_took);
    if (!applied)
        co_return proto::make_refusal(0, ReplyCode::refused, applied.error().message);
    if (!connection->remote) {
        auto* inlet = static_cast<Inlet*>(connection->sink.get());
        auto inlet_applied =
            co_await apply_on_worker(inlet->monitors, asked, results, any_setparam, recv_took);
        if (!inlet_applied)
            co_return proto::make_refusal(0, ReplyCode::refused, inlet_applied.error().message);
    } else {
        proto::ParamRecvRequest recv_asked;
        static_cast<proto::ParamArguments&>(recv_asked) = asked;
        // The far end rewrites its copy of the carrier text too: it needs to know which send-side
        // clauses took the values.
        recv_asked.send_took.assign(send_took.begin(), send_took.end());
        proto::Request recv_half;
        recv_half.body = recv_asked.encode();
        auto reply = co_await forward(recv_half, false, destination);
        if (reply.code != ReplyCode::ok)
            co_return reply;
        auto recv_answer = proto::ParamReply::decode(reply.body);
        if (!recv_answer)
            co_return refuse(recv_answer.error().message);
        for (auto& entry : recv_answer->monitors)
            results.push_back(std::move(entry));
        any_setparam = any_setparam || recv_answer->any_setparam;
        recv_took.assign(recv_answer->took.begin(), recv_answer->took.end());
    }
    if (action == "set" && !any_setparam) {
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "no monitor on " + source + " -> " + destination + " has setparam");
    }
    // The connection may have gone during the co_awaits: a carrier sent to the name server now
    // would bring it back into `plexus list`.
    const bool still_connected =
        std::find(port->outgoing.begin(), port->outgoing.end(), connection) != port->outgoing.end();
    if (action == "set" && still_connected) {
        const std::string carrier = with_values(connection->carrier, send_took, recv_took, asked.values);
        if (carrier != connection->carrier) {
            connection->carrier = carrier;
            if (!connection->remote)
                static_cast<Inlet*>(connection->sink.get())->set_carrier(carrier);
            // The name server merges an add_connection with the one it knows (same source and
            // destination): only the carrier text changes there.
            names::ConnectionEntry entry{source, destination, carrier, connection->persistent};
            if (auto told = co_await host_.names().add_connection(std::move(entry)); !told)
                spdlog::warn("name server: cannot update the carrier of {} -> {}: {}", source, destination,
                             told.error().message);
        }
    }
    co_return answer(std::move(results), any_setparam, action);
}

Task<proto::Reply> ControlPlane::param_recv(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto decoded = proto::ParamRecvRequest::decode(request.body);
    if (!decoded)
        co_return malformed(decoded.error());
    const proto::ParamRecvRequest& asked = *decoded;
    const std::string& source = asked.source;
    const std::string& destination = asked.destination;
    if (auto allowed = permitted(session.get(), Action::monitor, destination); !allowed)
        co_return proto::make_refusal(0, ReplyCode::refused, allowed.error().message);
    auto port = host_.router().find(destination);
    if (!port)
        co_return proto::make_refusal(0, ReplyCode::refused,
                                      "port " + destination + " is not on this daemon");
    std::vector<proto::MonitorParams> results;
    bool any_setparam = false;
    // The inlets are gathered first: a connection made or removed while a worker applies the
    // parameters changes port->inbound, which a loop over it across the co_await would not survive.
    std::vector<std::shared_ptr<Inlet>> inlets;
    for (const auto& weak : port->inbound) {
        if (auto inlet = weak.lock(); inlet && inlet->source() == source)
            inlets.push_back(std::move(inlet));
    }
    const Takers send_took(asked.send_took.begin(), asked.send_took.end());
    Takers took;
    for (const auto& inlet : inlets) {
        Takers inlet_took;
        auto applied = co_await apply_on_worker(inlet->monitors, asked, results, any_setparam, inlet_took);
        if (!applied)
            co_return proto::make_refusal(0, ReplyCode::refused, applied.error().message);
        // This end's copy of the carrier text, as the sending end rewrites its own (param()).
        if (asked.action == "set")
            inlet->set_carrier(with_values(inlet->carrier(), send_took, inlet_took, asked.values));
        took.insert(took.end(), inlet_took.begin(), inlet_took.end());
    }
    co_return answer(std::move(results), any_setparam, asked.action, took);
}

}  // namespace plexus::daemon
