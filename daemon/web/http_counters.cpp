#include "http_counters.hpp"

namespace plexus::daemon::web {

namespace {
constexpr std::array<std::string_view, refused_kinds> names{
    "too_many_connections", "header_too_large", "body", "bad_request", "not_found", "method", "token", "host",
    "read_timeout",         "slow_stream"};
static_assert(static_cast<std::size_t>(Refused::slow_stream) + 1 == refused_kinds);
}  // namespace

std::string_view refused_name(Refused reason) {
    return names[static_cast<std::size_t>(reason)];
}

nlohmann::json HttpCounters::to_json() const {
    nlohmann::json by_reason = nlohmann::json::object();
    for (std::size_t i = 0; i < refused_kinds; ++i)
        by_reason[std::string(names[i])] = refused[i];
    return {{"connections_accepted", connections_accepted},
            {"connections_open", connections_open},
            {"requests", requests},
            {"stream_clients", stream_clients},
            {"stream_events", stream_events},
            {"refused", std::move(by_reason)}};
}

}  // namespace plexus::daemon::web
