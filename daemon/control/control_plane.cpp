// The op table and its dispatch: which handler answers an op, and which sessions may send it.
#include "control_plane.hpp"

#include <algorithm>
#include <iterator>

#include "net/session.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

using proto::Op;

// `open`, `close` and `shm` concern a client's own ports; `attach` turns a link session into the
// receiving end of a connection; the rest are questions and commands anyone may send.
const ControlPlane::Operation ControlPlane::operations_[] = {
    {Op::open, Callers::client, &ControlPlane::open_port},
    {Op::close, Callers::client, &ControlPlane::close_port},
    {Op::shm, Callers::client, &ControlPlane::shm},
    {Op::attach, Callers::link, &ControlPlane::attach},
    {Op::connect, Callers::any, &ControlPlane::connect},
    {Op::disconnect, Callers::any, &ControlPlane::disconnect},
    {Op::stats, Callers::any, &ControlPlane::stats},
    {Op::param, Callers::any, &ControlPlane::param},
    {Op::param_recv, Callers::any, &ControlPlane::param_recv},
    {Op::ping, Callers::any, &ControlPlane::ping},
    {Op::events, Callers::any, &ControlPlane::events},
    {Op::node, Callers::any, &ControlPlane::node},
    {Op::lookup, Callers::any, &ControlPlane::lookup},
    {Op::list, Callers::any, &ControlPlane::list},
    {Op::inspect, Callers::any, &ControlPlane::inspect},
    {Op::record_start, Callers::any, &ControlPlane::record_start},
    {Op::record_status, Callers::any, &ControlPlane::record_status},
    {Op::record_stop, Callers::any, &ControlPlane::record_stop},
    {Op::report, Callers::client, &ControlPlane::report},
};

const ControlPlane::Operation* ControlPlane::find_operation(Op op, const std::string& role) {
    const auto* row = std::find_if(std::begin(operations_), std::end(operations_),
                                   [&](const Operation& candidate) { return op == candidate.op; });
    if (row == std::end(operations_))
        return nullptr;
    switch (row->callers) {
        case Callers::client:
            return role == "client" ? row : nullptr;
        case Callers::link:
            return role == "link" ? row : nullptr;
        case Callers::any:
            break;
    }
    return row;
}

ControlPlane::ControlPlane(asio::any_io_executor executor, ControlHost& host)
    : executor_(std::move(executor)), host_(host), permissions_(host.config().permissions) {}

Task<proto::Reply> ControlPlane::handle(std::shared_ptr<Session> session, proto::Request request) {
    const std::string op = request.body["op"];
    const auto known = proto::op_named(op);
    const Operation* found = known ? find_operation(*known, session->role()) : nullptr;
    if (!found) {
        co_return refuse("unknown request '" + op + "' for a " + session->role() + " session",
                         proto::ReplyCode::usage);
    }
    const Handler handler = found->handler;
    co_return co_await (this->*handler)(session, request);
}

proto::Hello ControlPlane::our_hello(const char* role) const {
    proto::Hello hello;
    hello.role = role;
    hello.node = host_.config().node;
    return hello;
}

std::function<void()> ControlPlane::space_notifier() {
    return [&host = host_] { host.notify_space(); };
}

}  // namespace plexus::daemon
