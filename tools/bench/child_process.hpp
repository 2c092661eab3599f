#pragma once
// Child processes of the bench (plexusd, relays): started here, stopped with SIGTERM and reaped when
// their handle goes away, also when a measurement throws. Nothing sleeps for a fixed time: waits
// poll a condition against a deadline.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace plexus::bench {

/// Polls `condition` until it holds or `timeout` passes; true if it held.
bool poll_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout);

/// A running child process with stdout and stderr sent to `log_path`; stopped on destruction.
class ChildProcess {
public:
    ChildProcess(const std::vector<std::string>& argv, const std::string& log_path);
    ~ChildProcess();
    ChildProcess(const ChildProcess&) = delete;
    ChildProcess& operator=(const ChildProcess&) = delete;

    pid_t pid() const { return pid_; }
    /// True while the process has not exited (reaps it if it has).
    bool running();
    /// The last lines of its log, for error messages.
    std::string log_tail() const;

private:
    pid_t pid_ = -1;
    bool reaped_ = false;
    std::string log_path_;
};

/// A fresh directory under /tmp (short: Unix socket paths are limited to 107 bytes), removed afterwards.
class TempDir {
public:
    TempDir();
    ~TempDir();
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string file(const std::string& name) const { return path_ + "/" + name; }
    const std::string& path() const { return path_; }

private:
    std::string path_;
};

/// Reads a whole file; empty if it cannot be read.
std::string read_file(const std::string& path);

}  // namespace plexus::bench
