// The functions a monitor uses to take part in its input port's arbitration (DESIGN, "Port
// monitors"): setEvent, unsetEvent, hasEvent, setConstraint, getConstraint. Lua scripts reach them
// through lua_monitor.cpp, plugins through plugin_api.cpp; both get these errors.
#include <mutex>

#include <spdlog/spdlog.h>

#include "monitor.hpp"

namespace plexus::daemon::monitor {

namespace {
/// Longest event lifetime a monitor may ask for: a day; longer is a mistake in units.
constexpr double max_lifetime = 86400;
}  // namespace

proto::Result<arbitration::Member*> Monitor::member_for(const char* function) const {
    if (!spec_.member)
        return proto::Error{std::string(function) +
                            ": only recv-side monitors take part in arbitration (the event container "
                            "belongs to the input port)"};
    return spec_.member.get();
}

void Monitor::release_events() {
    if (!spec_.member)
        return;
    std::lock_guard lock(spec_.member->arbiter().mutex());
    spec_.member->arbiter().events().remove_owner(id_);
}

proto::Status Monitor::set_event(const std::string& name, std::optional<double> lifetime) {
    if (lifetime && !(*lifetime >= 0 && *lifetime <= max_lifetime))
        return proto::Error{"setEvent: lifetime must be between 0 (none) and " +
                            std::to_string(max_lifetime) + " seconds"};
    if (name.empty())
        return proto::Error{"setEvent: the event name is empty"};
    auto member = member_for("setEvent");
    if (!member)
        return member.error();
    auto& arbiter = (*member)->arbiter();
    std::lock_guard lock(arbiter.mutex());
    arbiter.events().set(name, id_, (*member)->source() + " (" + spec_.script.name + ")", lifetime,
                         arbiter.now());
    return proto::Ok{};
}

proto::Status Monitor::unset_event(const std::string& name) {
    auto member = member_for("unsetEvent");
    if (!member)
        return member.error();
    std::lock_guard lock((*member)->arbiter().mutex());
    (*member)->arbiter().events().unset(name, id_);
    return proto::Ok{};
}

proto::Result<bool> Monitor::has_event(const std::string& name) {
    auto member = member_for("hasEvent");
    if (!member)
        return member.error();
    std::lock_guard lock((*member)->arbiter().mutex());
    return (*member)->arbiter().has_event(name);
}

proto::Status Monitor::set_constraint(const std::optional<std::string>& text) {
    auto found = member_for("setConstraint");
    if (!found)
        return found.error();
    arbitration::Member& member = **found;
    if (!text) {
        std::lock_guard lock(member.arbiter().mutex());
        member.constraint.reset();
        return proto::Ok{};
    }
    {
        std::lock_guard lock(member.arbiter().mutex());
        if (member.constraint && member.constraint->text() == *text)
            return proto::Ok{};  // monitors often set the same constraint on every message: no reparse, no
                                 // warning
    }
    auto parsed = arbitration::Constraint::parse(*text);
    if (!parsed)
        return proto::Error{"setConstraint: " + parsed.error().message};
    std::lock_guard lock(member.arbiter().mutex());
    member.constraint = std::move(*parsed);
    for (const auto& pair : member.arbiter().overlaps(&member)) {
        if (pair.first == member.source() || pair.second == member.source())
            spdlog::warn("monitor {}: constraint '{}' overlaps with the connection from {}", description(),
                         *text, pair.first == member.source() ? pair.second : pair.first);
    }
    return proto::Ok{};
}

proto::Result<std::optional<std::string>> Monitor::get_constraint() {
    auto member = member_for("getConstraint");
    if (!member)
        return member.error();
    std::lock_guard lock((*member)->arbiter().mutex());
    if (!(*member)->constraint)
        return std::optional<std::string>{};
    return std::optional<std::string>{(*member)->constraint->text()};
}

}  // namespace plexus::daemon::monitor
