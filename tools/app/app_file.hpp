#pragma once
// An application file (docs/APPLICATIONS.md): the components to start, the ports to wait for and
// the connections to make, read from JSON with its variables expanded. Reading reports every
// problem it finds, each naming the file, the entry and the field, and keeps the entries that
// are whole so that the checks after it can report theirs too.

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "expand.hpp"

namespace plexus::app {

struct Component {
    std::size_t index = 0;               ///< position in its section, for messages
    std::string section = "components";  ///< or "bridges": a plexus-bridge made into a component
    std::string name;
    std::string command;  ///< as written (expanded): a name looked up in PATH, or a path
    std::vector<std::string> args;
    std::map<std::string, std::string> env;
    std::string node;                ///< "" = the local daemon's node
    std::vector<std::string> ports;  ///< what `up` waits for after starting it
    /// `components[2] "world"`: how messages name it.
    std::string label() const;
};

struct AppConnection {
    std::size_t index = 0;  ///< position in "connections", for messages
    std::string source;
    std::string destination;
    std::string carrier;  ///< expanded; "" lets the daemon choose local or tcp
    bool persist = true;
    /// `connections[4] /world/object -> /gaze/in`: how messages name it.
    std::string label() const;
};

struct App {
    std::string file;       ///< the path it was read from, as given: what messages start with
    std::string directory;  ///< the file's directory, absolute: relative paths in it start here
    std::string name;
    std::string description;
    std::vector<std::string> scripts;  ///< script directories, absolute
    std::vector<Component> components;
    std::vector<std::string> wait;
    std::vector<AppConnection> connections;
};

struct Loaded {
    std::optional<App> app;             ///< none when the file cannot be read or is not JSON
    std::vector<std::string> problems;  ///< each "FILE: ENTRY: FIELD: what is wrong"
};

/// Reads and parses `path`.
Loaded load_app(const std::string& path, const VariableLookup& variables);
/// Parses `text` as if read from `path` (the directory of `path` anchors relative paths).
Loaded parse_app(const std::string& text, const std::string& path, const VariableLookup& variables);

}  // namespace plexus::app
