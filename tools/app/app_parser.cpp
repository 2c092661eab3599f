// The schema of application files: which fields exist, their types, and the variables in them.
// Every field other than the documented ones is an error (a misspelt "persist" that silently
// meant "true" would be worse than a refusal).
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app_file.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::app {

namespace {

using Json = nlohmann::json;

const std::vector<std::string> top_fields{"name",    "description", "scripts",    "components",
                                          "bridges", "wait",        "connections"};
const std::vector<std::string> component_fields{"name", "command", "args", "env", "node", "ports"};
const std::vector<std::string> bridge_fields{"name", "kind", "node", "domain", "broker",
                                             "in",   "out",  "args", "env"};
const std::vector<std::string> connection_fields{"source", "destination", "carrier", "persist"};

std::string joined(const std::vector<std::string>& words) {
    std::string out;
    for (const auto& word : words)
        out += (out.empty() ? "" : ", ") + word;
    return out;
}

/// Names used in file names (the state file, log files): no slashes, no dot files.
bool safe_name(const std::string& name) {
    if (name.empty() || name.size() > 100 || name.front() == '.')
        return false;
    for (const char c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
            return false;
    }
    return true;
}

/// Walks the JSON and records problems; one per file.
class Reader {
public:
    Reader(std::string file, const VariableLookup& variables)
        : file_(std::move(file)), variables_(variables) {}

    std::vector<std::string> problems;

    void problem(const std::string& entry, const std::string& text) {
        problems.push_back(file_ + ": " + (entry.empty() ? "" : entry + ": ") + text);
    }

    /// Unknown fields of an object: each one a problem.
    void only_known(const Json& object, const std::vector<std::string>& known, const std::string& entry) {
        for (const auto& [key, value] : object.items()) {
            if (std::find(known.begin(), known.end(), key) == known.end())
                problem(entry, "unknown field \"" + key + "\" (expected one of: " + joined(known) + ")");
        }
    }

    /// A string field; `expand` replaces its variables. None (after recording why) when wrong.
    std::optional<std::string> string(const Json& value, const std::string& entry, const std::string& field,
                                      bool expand) {
        if (!value.is_string()) {
            problem(entry, "\"" + field + "\": expected a string, found " + std::string(value.type_name()));
            return std::nullopt;
        }
        if (!expand)
            return value.get<std::string>();
        auto expanded = expand_variables(value.get<std::string>(), variables_);
        if (!expanded) {
            problem(entry, "\"" + field + "\": " + expanded.error().message);
            return std::nullopt;
        }
        return *expanded;
    }

    /// An array of strings; entries that are wrong are recorded and left out.
    std::optional<std::vector<std::string>> strings(const Json& value, const std::string& entry,
                                                    const std::string& field, bool expand) {
        if (!value.is_array()) {
            problem(entry, "\"" + field + "\": expected an array of strings, found " +
                               std::string(value.type_name()));
            return std::nullopt;
        }
        std::vector<std::string> out;
        bool whole = true;
        for (std::size_t i = 0; i < value.size(); ++i) {
            auto item = string(value[i], entry, field + "[" + std::to_string(i) + "]", expand);
            if (item)
                out.push_back(std::move(*item));
            else
                whole = false;
        }
        if (!whole)
            return std::nullopt;
        return out;
    }

    /// Port names: the rules of DESIGN ("Ports, messages, queues").
    bool port_name(const std::string& name, const std::string& entry, const std::string& field) {
        if (auto error = proto::port_name_error(name)) {
            problem(entry, "\"" + field + "\": " + *error);
            return false;
        }
        return true;
    }

    std::optional<Component> component(const Json& value, std::size_t index) {
        std::string entry = "components[" + std::to_string(index) + "]";
        if (!value.is_object()) {
            problem(entry, "expected an object, found " + std::string(value.type_name()));
            return std::nullopt;
        }
        Component c;
        c.index = index;
        bool whole = true;
        if (value.contains("name")) {
            if (auto name = string(value["name"], entry, "name", false)) {
                c.name = *name;
                entry = c.label();
                if (!safe_name(c.name)) {
                    problem(entry, "\"name\": use letters, digits, '_', '-' and '.' (it names the log file)");
                    whole = false;
                }
            } else {
                whole = false;
            }
        } else {
            problem(entry, "missing field \"name\"");
            whole = false;
        }
        only_known(value, component_fields, entry);
        if (value.contains("command")) {
            auto command = string(value["command"], entry, "command", true);
            if (command && command->empty())
                problem(entry, "\"command\": empty");
            if (command && !command->empty())
                c.command = *command;
            else
                whole = false;
        } else {
            problem(entry, "missing field \"command\"");
            whole = false;
        }
        if (value.contains("args")) {
            if (auto args = strings(value["args"], entry, "args", true))
                c.args = std::move(*args);
            else
                whole = false;
        }
        if (value.contains("env")) {
            const Json& env = value["env"];
            if (!env.is_object()) {
                problem(entry,
                        "\"env\": expected an object of strings, found " + std::string(env.type_name()));
                whole = false;
            } else {
                for (const auto& [key, item] : env.items()) {
                    if (key.empty() || key.find('=') != std::string::npos) {
                        problem(entry, "\"env\": bad variable name \"" + key + "\"");
                        whole = false;
                        continue;
                    }
                    if (auto text = string(item, entry, "env." + key, true))
                        c.env[key] = *text;
                    else
                        whole = false;
                }
            }
        }
        if (value.contains("node")) {
            if (auto node = string(value["node"], entry, "node", true))
                c.node = *node;
            else
                whole = false;
        }
        if (value.contains("ports")) {
            if (auto ports = strings(value["ports"], entry, "ports", true)) {
                for (std::size_t i = 0; i < ports->size(); ++i)
                    whole = port_name((*ports)[i], entry, "ports[" + std::to_string(i) + "]") && whole;
                c.ports = std::move(*ports);
            } else {
                whole = false;
            }
        }
        if (!whole)
            return std::nullopt;
        return c;
    }

    /// A `bridges` entry: plexus-bridge KIND started as a component, waited for by the Plexus ports
    /// its mappings name (docs/BRIDGES.md).
    std::optional<Component> bridge(const Json& value, std::size_t index) {
        std::string entry = "bridges[" + std::to_string(index) + "]";
        if (!value.is_object()) {
            problem(entry, "expected an object, found " + std::string(value.type_name()));
            return std::nullopt;
        }
        only_known(value, bridge_fields, entry);
        Json as_component = Json::object();
        for (const char* field : {"name", "node", "env"}) {
            if (value.contains(field))
                as_component[field] = value[field];
        }
        std::string kind;
        if (!value.contains("kind")) {
            problem(entry, "missing field \"kind\" (ros2 or mqtt)");
        } else if (auto text = string(value["kind"], entry, "kind", false)) {
            kind = *text;
            if (kind != "ros2" && kind != "mqtt")
                problem(entry, "\"kind\": expected ros2 or mqtt, found \"" + kind + "\"");
        }
        Json args = Json::array({kind});
        bool whole = kind == "ros2" || kind == "mqtt";
        if (value.contains("domain")) {
            const Json& domain = value["domain"];
            if (kind != "ros2" || !domain.is_number_unsigned() || domain.get<std::uint64_t>() > 232) {
                problem(entry, "\"domain\": a ROS 2 domain id (0 to 232) of a ros2 bridge");
                whole = false;
            } else {
                args.push_back("--domain");
                args.push_back(std::to_string(domain.get<std::uint64_t>()));
            }
        }
        if (value.contains("broker")) {
            auto broker = string(value["broker"], entry, "broker", true);
            if (kind != "mqtt" || !broker) {
                problem(entry, "\"broker\": HOST:PORT, for an mqtt bridge");
                whole = false;
            } else {
                args.push_back("--broker");
                args.push_back(*broker);
            }
        }
        std::vector<std::string> ports;
        for (const char* direction : {"in", "out"}) {
            if (!value.contains(direction))
                continue;
            const auto mappings = strings(value[direction], entry, direction, true);
            if (!mappings) {
                whole = false;
                continue;
            }
            for (std::size_t i = 0; i < mappings->size(); ++i) {
                const std::string& mapping = (*mappings)[i];
                const std::string field = std::string(direction) + "[" + std::to_string(i) + "]";
                // The Plexus side: after '=' going in (before the type's ':' for ros2), before it going out.
                const auto equals = mapping.find('=');
                std::string port;
                if (equals != std::string::npos) {
                    port = std::string(direction) == "in" ? mapping.substr(equals + 1)
                                                          : mapping.substr(0, equals);
                    if (kind == "ros2" && std::string(direction) == "in")
                        port = port.substr(0, port.rfind(':'));
                }
                if (equals == std::string::npos || !port_name(port, entry, field)) {
                    if (equals == std::string::npos)
                        problem(entry, "\"" + field + "\": expected " +
                                           (std::string(direction) == "in" ? "TOPIC=PORT" : "PORT=TOPIC") +
                                           (kind == "ros2" ? ":TYPE" : ""));
                    whole = false;
                    continue;
                }
                args.push_back("--" + std::string(direction));
                args.push_back(mapping);
                ports.push_back(port);
            }
        }
        if (ports.empty() && whole) {
            problem(entry, "nothing to bridge: give \"in\" or \"out\" mappings");
            whole = false;
        }
        if (value.contains("args")) {
            for (const auto& extra :
                 strings(value["args"], entry, "args", true).value_or(std::vector<std::string>{}))
                args.push_back(extra);
        }
        as_component["command"] = "plexus-bridge";
        as_component["args"] = args;
        as_component["ports"] = ports;
        const auto before = problems.size();
        auto made = component(as_component, index);
        // The component's own messages name it components[i]: say bridges[i] instead.
        for (auto it = problems.begin() + static_cast<std::ptrdiff_t>(before); it != problems.end(); ++it) {
            if (const auto at = it->find("components["); at != std::string::npos)
                it->replace(at, 11, "bridges[");
        }
        if (!made || !whole)
            return std::nullopt;
        made->section = "bridges";
        return made;
    }

    std::optional<AppConnection> connection(const Json& value, std::size_t index) {
        std::string entry = "connections[" + std::to_string(index) + "]";
        if (!value.is_object()) {
            problem(entry, "expected an object, found " + std::string(value.type_name()));
            return std::nullopt;
        }
        AppConnection c;
        c.index = index;
        bool whole = true;
        // Both ends first: the entry's name in later messages is "connections[i] SRC -> DST".
        for (const char* field : {"source", "destination"}) {
            std::string& end = std::string(field) == "source" ? c.source : c.destination;
            if (!value.contains(field)) {
                problem(entry, std::string("missing field \"") + field + "\"");
                whole = false;
            } else if (auto text = string(value[field], entry, field, true)) {
                end = *text;
            } else {
                whole = false;
            }
        }
        if (whole)
            entry = c.label();
        only_known(value, connection_fields, entry);
        if (whole) {
            whole = port_name(c.source, entry, "source") && whole;
            whole = port_name(c.destination, entry, "destination") && whole;
        }
        if (value.contains("carrier")) {
            if (auto carrier = string(value["carrier"], entry, "carrier", true))
                c.carrier = *carrier;
            else
                whole = false;
        }
        if (value.contains("persist")) {
            if (value["persist"].is_boolean()) {
                c.persist = value["persist"].get<bool>();
            } else {
                problem(entry, "\"persist\": expected true or false, found " +
                                   std::string(value["persist"].type_name()));
                whole = false;
            }
        }
        if (!whole)
            return std::nullopt;
        return c;
    }

    App app(const Json& root, const std::string& path) {
        App a;
        a.file = path;
        std::error_code ec;
        a.directory = std::filesystem::absolute(std::filesystem::path(path), ec)
                          .parent_path()
                          .lexically_normal()
                          .string();
        only_known(root, top_fields, "");
        if (!root.contains("name")) {
            problem("", "missing field \"name\" (it names the state `up` keeps)");
        } else if (auto name = string(root["name"], "", "name", false)) {
            a.name = *name;
            if (!safe_name(a.name))
                problem("", "\"name\": use letters, digits, '_', '-' and '.' (it names the state file)");
        }
        if (root.contains("description"))
            a.description = string(root["description"], "", "description", false).value_or("");
        if (root.contains("scripts")) {
            for (const auto& dir :
                 strings(root["scripts"], "", "scripts", true).value_or(std::vector<std::string>{}))
                a.scripts.push_back((std::filesystem::path(a.directory) / dir).lexically_normal().string());
        }
        if (root.contains("wait")) {
            auto ports = strings(root["wait"], "", "wait", true).value_or(std::vector<std::string>{});
            for (std::size_t i = 0; i < ports.size(); ++i) {
                if (port_name(ports[i], "", "wait[" + std::to_string(i) + "]"))
                    a.wait.push_back(ports[i]);
            }
        }
        if (root.contains("components")) {
            const Json& list = root["components"];
            if (!list.is_array()) {
                problem("", "\"components\": expected an array, found " + std::string(list.type_name()));
            } else {
                for (std::size_t i = 0; i < list.size(); ++i) {
                    if (auto c = component(list[i], i))
                        a.components.push_back(std::move(*c));
                }
            }
        }
        if (root.contains("bridges")) {
            const Json& list = root["bridges"];
            if (!list.is_array()) {
                problem("", "\"bridges\": expected an array, found " + std::string(list.type_name()));
            } else {
                for (std::size_t i = 0; i < list.size(); ++i) {
                    if (auto c = bridge(list[i], i))
                        a.components.push_back(std::move(*c));
                }
            }
        }
        if (root.contains("connections")) {
            const Json& list = root["connections"];
            if (!list.is_array()) {
                problem("", "\"connections\": expected an array, found " + std::string(list.type_name()));
            } else {
                for (std::size_t i = 0; i < list.size(); ++i) {
                    if (auto c = connection(list[i], i))
                        a.connections.push_back(std::move(*c));
                }
            }
        }
        return a;
    }

private:
    std::string file_;
    const VariableLookup& variables_;
};

}  // namespace

std::string Component::label() const {
    return section + "[" + std::to_string(index) + "] \"" + name + "\"";
}

std::string AppConnection::label() const {
    return "connections[" + std::to_string(index) + "] " + source + " -> " + destination;
}

Loaded parse_app(const std::string& text, const std::string& path, const VariableLookup& variables) {
    Loaded loaded;
    Reader reader(path, variables);
    Json root;
    try {
        root = Json::parse(text);
    } catch (const Json::exception& e) {
        // nlohmann's text names the byte: "parse error at line 3, column 7: syntax error ...". Not
        // only parse_error: a number too large for a double ("4E4448") is an out_of_range, which
        // used to escape parse_app and end `plexus check` with nlohmann's text and no file name.
        reader.problem("", std::string("not valid JSON: ") + e.what());
        loaded.problems = std::move(reader.problems);
        return loaded;
    }
    if (!root.is_object()) {
        reader.problem("", "expected a JSON object at the top, found " + std::string(root.type_name()));
        loaded.problems = std::move(reader.problems);
        return loaded;
    }
    loaded.app = reader.app(root, path);
    loaded.problems = std::move(reader.problems);
    return loaded;
}

Loaded load_app(const std::string& path, const VariableLookup& variables) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        Loaded loaded;
        loaded.problems.push_back(path + ": cannot read the file: " + std::strerror(errno));
        return loaded;
    }
    std::ostringstream text;
    text << in.rdbuf();
    return parse_app(text.str(), path, variables);
}

}  // namespace plexus::app
