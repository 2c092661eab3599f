// The functions a script uses to take part in its input port's arbitration (DESIGN, "Port
// monitors"): setEvent, unsetEvent, hasEvent, setConstraint, getConstraint.
#include <mutex>

#include <spdlog/spdlog.h>

#include "lua_guard.hpp"
#include "monitor.hpp"

namespace plexus::daemon::monitor {

namespace {
/// Longest event lifetime a script may ask for: a day; longer is a mistake in units.
constexpr double max_lifetime = 86400;
}  // namespace

arbitration::Member& Monitor::member_of(lua_State* L, const char* function) {
    Monitor& monitor = self(L);
    if (!monitor.spec_.member)
        luaL_error(L,
                   "%s: only recv-side monitors take part in arbitration (the event container "
                   "belongs to the input port)",
                   function);
    return *monitor.spec_.member;
}

void Monitor::release_events() {
    if (!spec_.member)
        return;
    std::lock_guard lock(spec_.member->arbiter().mutex());
    spec_.member->arbiter().events().remove_owner(id_);
}

int Monitor::api_set_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    std::optional<double> lifetime;
    if (!lua_isnoneornil(L, 2)) {
        const double seconds = luaL_checknumber(L, 2);
        if (!(seconds >= 0 && seconds <= max_lifetime))
            return luaL_error(L, "setEvent: lifetime must be between 0 (none) and %f seconds", max_lifetime);
        lifetime = seconds;
    }
    if (name.empty())
        return luaL_error(L, "setEvent: the event name is empty");
    auto& member = member_of(L, "setEvent");
    return guard(L, [&] {
        Monitor& monitor = self(L);
        auto& arbiter = member.arbiter();
        std::lock_guard lock(arbiter.mutex());
        arbiter.events().set(name, monitor.id_, member.source() + " (" + monitor.spec_.script.name + ")",
                             lifetime, arbiter.now());
        return 0;
    });
}

int Monitor::api_unset_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    auto& member = member_of(L, "unsetEvent");
    return guard(L, [&] {
        std::lock_guard lock(member.arbiter().mutex());
        member.arbiter().events().unset(name, self(L).id_);
        return 0;
    });
}

int Monitor::api_has_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    auto& member = member_of(L, "hasEvent");
    bool has = false;
    {
        std::lock_guard lock(member.arbiter().mutex());
        has = member.arbiter().has_event(name);
    }
    lua_pushboolean(L, has ? 1 : 0);
    return 1;
}

int Monitor::api_set_constraint(lua_State* L) {
    auto& member = member_of(L, "setConstraint");
    if (lua_isnoneornil(L, 1)) {
        std::lock_guard lock(member.arbiter().mutex());
        member.constraint.reset();
        return 0;
    }
    const std::string text = luaL_checkstring(L, 1);
    {
        std::lock_guard lock(member.arbiter().mutex());
        if (member.constraint && member.constraint->text() == text)
            return 0;  // scripts often set the same constraint on every message: no reparse, no warning
    }
    auto parsed = arbitration::Constraint::parse(text);
    if (!parsed)
        return luaL_error(L, "setConstraint: %s", parsed.error().message.c_str());
    return guard(L, [&] {
        std::lock_guard lock(member.arbiter().mutex());
        member.constraint = std::move(*parsed);
        for (const auto& pair : member.arbiter().overlaps(&member)) {
            if (pair.first == member.source() || pair.second == member.source())
                spdlog::warn("monitor {}: constraint '{}' overlaps with the connection from {}",
                             self(L).description(), text,
                             pair.first == member.source() ? pair.second : pair.first);
        }
        return 0;
    });
}

int Monitor::api_get_constraint(lua_State* L) {
    auto& member = member_of(L, "getConstraint");
    std::optional<std::string> text;
    {
        std::lock_guard lock(member.arbiter().mutex());
        if (member.constraint)
            text = member.constraint->text();
    }
    if (!text)
        lua_pushnil(L);
    else
        lua_pushlstring(L, text->data(), text->size());
    return 1;
}

}  // namespace plexus::daemon::monitor
