#include "permissions.hpp"

#include <pwd.h>

#include <algorithm>
#include <fstream>

#include <nlohmann/json.hpp>

namespace plexus::daemon {

namespace {

using nlohmann::json;

constexpr std::pair<std::string_view, Action> actions[] = {{"open", Action::open},
                                                           {"write", Action::write},
                                                           {"read", Action::read},
                                                           {"connect", Action::connect},
                                                           {"monitor", Action::monitor}};

/// Glob matching where `*` may not cross `stop` (pass '\0' to let it cross anything) and `**`
/// crosses everything. Iterative, with one back-tracking point per star kind: linear enough for
/// names of at most a few hundred bytes.
bool glob(std::string_view pattern, std::string_view text, char stop) {
    std::size_t p = 0;
    std::size_t t = 0;
    std::size_t star_p = std::string_view::npos;  // after the last star seen
    std::size_t star_t = 0;
    bool star_crosses = false;
    while (t < text.size()) {
        if (p < pattern.size() && pattern[p] == '*') {
            star_crosses = p + 1 < pattern.size() && pattern[p + 1] == '*';
            p += star_crosses ? 2 : 1;
            star_p = p;
            star_t = t;
            continue;
        }
        if (p < pattern.size() && pattern[p] == text[t]) {
            ++p;
            ++t;
            continue;
        }
        // Let the last star take one more character, if it may.
        if (star_p != std::string_view::npos && (star_crosses || stop == '\0' || text[star_t] != stop)) {
            ++star_t;
            t = star_t;
            p = star_p;
            continue;
        }
        return false;
    }
    while (p < pattern.size() && pattern[p] == '*')
        ++p;
    return p == pattern.size();
}

proto::Result<std::vector<std::string>> texts(const json& rule, const char* key, const std::string& where) {
    std::vector<std::string> out;
    if (!rule.contains(key))
        return out;
    if (!rule[key].is_array())
        return proto::Error{where + ": \"" + key + "\" must be a list of texts"};
    for (const auto& item : rule[key]) {
        if (!item.is_string() || item.get<std::string>().empty())
            return proto::Error{where + ": \"" + key + "\" must be a list of texts"};
        out.push_back(item.get<std::string>());
    }
    return out;
}

}  // namespace

std::string_view action_name(Action action) {
    for (const auto& [name, known] : actions) {
        if (known == action)
            return name;
    }
    return "?";
}

std::string Principal::text() const {
    if (node)
        return "node '" + *node + "'";
    if (user)
        return "user " + std::to_string(*user);
    return "an unnamed peer";
}

bool port_matches(std::string_view pattern, std::string_view port) {
    return glob(pattern, port, '/');
}

bool node_matches(std::string_view pattern, std::string_view node) {
    return glob(pattern, node, '\0');
}

proto::Result<Permissions> Permissions::load(const std::string& path) {
    std::ifstream in(path);
    if (!in)
        return proto::Error{"cannot read the permissions file " + path};
    json file = json::parse(in, nullptr, false);
    if (file.is_discarded())
        return proto::Error{"the permissions file " + path + " is not JSON"};
    return parse(file, path);
}

proto::Result<Permissions> Permissions::parse(const json& file, const std::string& source) {
    Permissions permissions;
    permissions.source_ = source;
    if (!file.is_object() || !file.contains("rules") || !file["rules"].is_array())
        return proto::Error{source + ": a permissions file is {\"rules\": [...]}"};
    for (const auto& [key, value] : file.items()) {
        if (key != "rules")
            return proto::Error{source + ": unknown key \"" + key + "\" (only \"rules\")"};
    }
    int index = 0;
    for (const auto& entry : file["rules"]) {
        const std::string where = source + ": rule " + std::to_string(++index);
        if (!entry.is_object())
            return proto::Error{where + " is not an object"};
        for (const auto& [key, value] : entry.items()) {
            if (key != "nodes" && key != "users" && key != "allow" && key != "ports")
                return proto::Error{where + ": unknown key \"" + key + "\" (nodes, users, allow, ports)"};
        }
        Rule rule;
        auto nodes = texts(entry, "nodes", where);
        auto ports = texts(entry, "ports", where);
        auto allowed = texts(entry, "allow", where);
        if (!nodes)
            return nodes.error();
        if (!ports)
            return ports.error();
        if (!allowed)
            return allowed.error();
        rule.nodes = std::move(*nodes);
        rule.ports = std::move(*ports);
        if (entry.contains("users")) {
            if (!entry["users"].is_array())
                return proto::Error{where + ": \"users\" must be a list of uids or user names"};
            for (const auto& user : entry["users"]) {
                if (user.is_number_unsigned()) {
                    rule.users.push_back(user.get<uid_t>());
                } else if (user.is_string()) {
                    const passwd* found = ::getpwnam(user.get<std::string>().c_str());
                    if (!found)
                        return proto::Error{where + ": no user named '" + user.get<std::string>() + "'"};
                    rule.users.push_back(found->pw_uid);
                } else {
                    return proto::Error{where + ": \"users\" must be a list of uids or user names"};
                }
            }
        }
        for (const auto& name : *allowed) {
            const auto* known = std::find_if(std::begin(actions), std::end(actions),
                                             [&](const auto& action) { return action.first == name; });
            if (known == std::end(actions))
                return proto::Error{where + ": unknown action \"" + name +
                                    "\" (open, write, read, connect, monitor)"};
            rule.actions |= static_cast<unsigned>(known->second);
        }
        if (rule.nodes.empty() && rule.users.empty())
            return proto::Error{where + " names no one: give \"nodes\" or \"users\""};
        if (rule.ports.empty() || rule.actions == 0)
            return proto::Error{where + " allows nothing: give \"allow\" and \"ports\""};
        permissions.rules_.push_back(std::move(rule));
    }
    return permissions;
}

bool Permissions::allows(const Principal& who, Action action, std::string_view port) const {
    for (const auto& rule : rules_) {
        if ((rule.actions & static_cast<unsigned>(action)) == 0)
            continue;
        const bool named =
            (who.node &&
             std::any_of(rule.nodes.begin(), rule.nodes.end(),
                         [&](const std::string& pattern) { return node_matches(pattern, *who.node); })) ||
            (who.user && std::find(rule.users.begin(), rule.users.end(), *who.user) != rule.users.end());
        if (!named)
            continue;
        if (std::any_of(rule.ports.begin(), rule.ports.end(),
                        [&](const std::string& pattern) { return port_matches(pattern, port); }))
            return true;
    }
    return false;
}

}  // namespace plexus::daemon
