#include "port_counters.hpp"

#include <spdlog/spdlog.h>

namespace plexus::bridge {

PortCounters::PortCounters(std::string port, std::string peer)
    : port_(std::move(port)), peer_(std::move(peer)) {}

void PortCounters::dropped(const std::string& reason, const std::string& detail) {
    std::uint64_t count = 0;
    {
        std::lock_guard lock(mutex_);
        count = ++dropped_[reason];
    }
    if (count == 1)
        spdlog::warn(
            "{} <-> {}: a message was not passed on ({}): {}; further ones for this reason are "
            "counted (plexus stats {}), not logged",
            port_, peer_, reason, detail, port_);
}

std::uint64_t PortCounters::dropped_count(const std::string& reason) const {
    std::lock_guard lock(mutex_);
    const auto it = dropped_.find(reason);
    return it == dropped_.end() ? 0 : it->second;
}

Value PortCounters::snapshot() const {
    Value out = Value::object();
    out["passed"] = passed_count();
    std::lock_guard lock(mutex_);
    for (const auto& [reason, count] : dropped_)
        out[reason] = count;
    return out;
}

}  // namespace plexus::bridge
