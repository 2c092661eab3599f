#pragma once
// The `plexus` commands. Each returns the process exit status of DESIGN's contract:
// 0 success, 1 a "no" answer, 2 usage error, 3 timeout, 4 refused by the system.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "plexus/client.hpp"

namespace plexus::cli {

struct Common {
    explicit Common(std::string socket_path) : socket(std::move(socket_path)) {}
    std::optional<std::string> names_flag;  ///< --names, when given
    std::string socket;                     ///< local daemon socket
    /// The name server's HOST:PORT, looked for on first use (flag, PLEXUS_NAMES, config file,
    /// multicast discovery, default): commands that never need it never wait for discovery.
    const std::string& names() const { return names_choice().address; }
    const NamesLocation& names_choice() const;

private:
    mutable std::optional<NamesLocation> found_;
};

struct ReadOptions {
    std::string port;
    std::string source;
    std::string carrier;
    std::optional<long> count;
    std::optional<double> timeout;
    bool envelope = false;
    std::string policy = "strict";
    std::size_t capacity = 0;
};

struct EventsOptions {
    std::string port;
    bool check = false;
    bool watch = false;
    bool json = false;
    double interval = 0.5;      ///< seconds between redraws with --watch
    std::optional<long> count;  ///< with --watch: stop after this many redraws
};

/// `plexus what-if FILE PORT`: the recording's arbitration of PORT re-run offline (tools/record/).
struct WhatIfArgs {
    std::string file;
    std::string port;
    std::vector<std::string> carriers;  ///< SOURCE=CARRIER, as given
    bool json = false;
    std::string svg;  ///< "" = no picture
    std::vector<std::string> script_dirs;
    std::vector<std::string> monitor_lib_dirs;
};

struct RecordOptions {
    std::vector<std::string> ports;
    std::string output;
    bool all = false;
    std::optional<double> duration;  ///< seconds; none: until Ctrl-C
    std::uint64_t max_bytes = 0;
    std::uint64_t split_bytes = 0;
    std::string info;  ///< --info FILE
    bool json = false;
};

struct CallOptions {
    std::string port;
    std::string value;    ///< JSON if it parses, else a string
    double timeout = 10;  ///< seconds
};
/// `plexus call`: one request to the service at PORT; its answer as one JSON line.
int call(const Common& common, const CallOptions& options);

struct ServeOptions {
    std::string port;
    bool echo = false;
    std::string exec;  ///< a shell command: the request on its stdin, the answer from its stdout
};
/// `plexus serve`: answers the calls of PORT until SIGINT/SIGTERM.
int serve(const Common& common, const ServeOptions& options);

struct PlayOptions {
    std::string file;
    double rate = 1.0;
    bool loop = false;
    std::vector<std::string> remaps;  ///< OLD=NEW
    double start = 0;                 ///< seconds from the recording's start
    std::optional<double> end;
    std::vector<std::string> ports;  ///< the recorded ports whose sources to play; all when empty
    double wait = 5;                 ///< seconds to wait for connections out of the opened ports
};

/// `plexus record`: the local daemon records ports into a file (docs/RECORDING.md).
int record(const Common& common, const RecordOptions& options);
/// `plexus play`: the recorded sources' messages written again, with their timing.
int play(const Common& common, const PlayOptions& options);

int list(const Common& common, bool json);
/// `plexus where`: the name server's address and how it was found.
int where(const Common& common);
int connect(const Common& common, const std::string& source, const std::string& destination,
            const std::string& carrier, bool persist, bool strict);
int disconnect(const Common& common, const std::string& source, const std::string& destination);
int write(const Common& common, const std::string& port, const std::vector<std::string>& destinations);
int read(const Common& common, const ReadOptions& options);
int exists(const Common& common, const std::string& port, const std::string& destination);
int wait(const Common& common, const std::string& port, double timeout);
int ping(const Common& common, const std::string& port, int count);
int stats(const Common& common, const std::string& port, bool json);
/// The event container, constraints, stimulation and counters of an input port; exit 1 when
/// --check finds two connections that can deliver at once.
int events(const Common& common, const EventsOptions& options);
/// `plexus web`: the local daemon's web page address; with `token`, the web token instead.
int web(const Common& common, bool token);
/// Re-runs PORT's decisions from a recording, with some connections' carriers replaced, and
/// prints those that differ; exit 0 whatever the count, 2 for bad arguments, 4 for a bad file.
int what_if(const WhatIfArgs& args);
/// Prints, as a JSON array, {script, side, param} for each monitor on SRC -> DST; `set` calls
/// setparam with the KEY=VALUE pairs first.
int param(const Common& common, const std::string& action, const std::string& source,
          const std::string& destination, const std::vector<std::string>& assignments);

}  // namespace plexus::cli
