#pragma once
// What `up` remembers between runs, per user and per application: the components it started
// (PID, the kernel's start time of that PID, log file), in `<directory of the daemon's
// socket>/apps/<name>.json`, written atomically (a temporary file renamed over it). The start
// time tells our component from an unrelated process that got its PID later.

#include <sys/types.h>

#include <map>
#include <string>

namespace plexus::cli {

struct ComponentRecord {
    pid_t pid = 0;                      ///< also its process group: it was started in a session of its own
    unsigned long long start_time = 0;  ///< field 22 of /proc/PID/stat (clock ticks after boot)
    std::string log;
    std::string node;
    std::string socket;      ///< the PLEXUS_SOCKET it was given
    std::string started_at;  ///< wall-clock time, for people
};

struct AppState {
    std::string file;                                   ///< the application file `up` read
    std::map<std::string, ComponentRecord> components;  ///< by component name
};

/// `<dir of socket>/apps`: where states and logs live.
std::string apps_directory(const std::string& socket);
std::string state_path(const std::string& socket, const std::string& app_name);
/// `<apps>/<app>/<component>.log`.
std::string log_path(const std::string& socket, const std::string& app_name, const std::string& component);

/// The state, or an empty one when there is no file. Throws Error (usage) for a file that is not ours.
AppState read_state(const std::string& path);
/// Writes atomically; removes the file when no component is left.
void write_state(const std::string& path, const AppState& state);

}  // namespace plexus::cli
