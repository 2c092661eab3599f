#pragma once
// Starting and stopping the processes of an application's components. Each runs in a session
// and process group of its own (so a Ctrl-C at the terminal of `up` does not reach it, and `down`
// stops it with whatever it started), its stdout and stderr appended to a log file.

#include <sys/types.h>

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "app_state.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::cli {

/// The kernel's start time of `pid` (field 22 of /proc/PID/stat); none if there is no such
/// process or it has exited and waits to be reaped (a zombie runs nothing).
std::optional<unsigned long long> process_start_time(pid_t pid);

/// True when the record's PID is still the process `up` started (not a later one with its PID).
bool still_running(const ComponentRecord& record);

struct Launch {
    std::string program;  ///< an executable path
    std::vector<std::string> args;
    std::map<std::string, std::string> env;  ///< added to (or replacing in) this process's environment
    std::string log;
};

/// Forks and executes; the error says why exec failed (reported through a close-on-exec pipe, so a
/// missing program is an error here and not a silent exit in the log).
proto::Result<ComponentRecord> start_process(const Launch& launch);

/// The exit status of a child of this process that has ended (reaping it), or none while it runs.
/// For a process that is not our child, none.
std::optional<int> exited_child(pid_t pid);

/// How stop_processes ended each one.
enum class Stopped { terminated, killed, gone };

/// SIGTERM to each one's process group, up to `grace` for them all to exit, then SIGKILL to the
/// groups still there. Only records that are still_running are signalled; the others are `gone`.
std::vector<Stopped> stop_processes(const std::vector<ComponentRecord>& records,
                                    std::chrono::milliseconds grace = std::chrono::seconds(5));

}  // namespace plexus::cli
