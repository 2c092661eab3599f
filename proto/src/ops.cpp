#include "plexus/proto/ops.hpp"

#include <array>
#include <utility>

namespace plexus::proto {

namespace {
// In the enum's order: op_name indexes it.
constexpr std::array<std::pair<Op, std::string_view>, 26> names{{
    {Op::open, "open"},
    {Op::close, "close"},
    {Op::shm, "shm"},
    {Op::attach, "attach"},
    {Op::connect, "connect"},
    {Op::disconnect, "disconnect"},
    {Op::stats, "stats"},
    {Op::param, "param"},
    {Op::param_recv, "param_recv"},
    {Op::ping, "ping"},
    {Op::events, "events"},
    {Op::node, "node"},
    {Op::lookup, "lookup"},
    {Op::list, "list"},
    {Op::inspect, "inspect"},
    {Op::record_start, "record_start"},
    {Op::record_status, "record_status"},
    {Op::record_stop, "record_stop"},
    {Op::report, "report"},
    {Op::register_node, "register_node"},
    {Op::register_port, "register_port"},
    {Op::unregister_port, "unregister_port"},
    {Op::add_connection, "add_connection"},
    {Op::remove_connection, "remove_connection"},
    {Op::mcast_group, "mcast_group"},
    {Op::discover, "discover"},
}};

constexpr bool in_enum_order() {
    for (std::size_t i = 0; i < names.size(); ++i) {
        if (static_cast<std::size_t>(names[i].first) != i)
            return false;
    }
    return names.back().first == Op::discover;
}
static_assert(in_enum_order(), "names must list every Op, in the enum's order");
}  // namespace

std::string_view op_name(Op op) {
    return names[static_cast<std::size_t>(op)].second;
}

std::optional<Op> op_named(std::string_view name) {
    for (const auto& [op, text] : names) {
        if (text == name)
            return op;
    }
    return std::nullopt;
}

nlohmann::json request_body(Op op, nlohmann::json fields) {
    nlohmann::json body = fields.is_object() ? std::move(fields) : nlohmann::json::object();
    body["op"] = std::string(op_name(op));
    return body;
}

}  // namespace plexus::proto
