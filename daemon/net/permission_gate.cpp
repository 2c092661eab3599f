#include "permission_gate.hpp"

#include <spdlog/spdlog.h>

namespace plexus::daemon {

namespace {
// Distinct refusals remembered for logging once; past this many, the rest are counted only (a
// peer inventing port names must not grow the set without bound).
constexpr std::size_t most_logged = 4096;
}  // namespace

proto::Status PermissionGate::reload() {
    if (!permissions_)
        return proto::Error{
            "no permissions file was given at start (--permissions): everything stays allowed"};
    auto fresh = Permissions::load(permissions_->source());
    if (!fresh)
        return proto::Error{fresh.error().message + " (the rules read before stay in force)"};
    permissions_ = std::make_shared<const Permissions>(std::move(*fresh));
    logged_.clear();
    return proto::Ok{};
}

std::string PermissionGate::summary() const {
    if (!permissions_)
        return "";
    return permissions_->source() + ": " + std::to_string(permissions_->rule_count()) + " rules";
}

proto::Status PermissionGate::check(const Principal& who, Action action, std::string_view port,
                                    std::string_view log_prefix) {
    if (!permissions_ || permissions_->allows(who, action, port))
        return proto::Ok{};
    ++refusals_;
    const std::string refusal = who.text() + " may not " + std::string(action_name(action)) + " " +
                                std::string(port) + " (permissions " + permissions_->source() + ")";
    if (logged_.size() < most_logged && logged_.insert(refusal).second)
        spdlog::warn("{}refused: {}", log_prefix, refusal);
    return proto::Error{refusal};
}

}  // namespace plexus::daemon
