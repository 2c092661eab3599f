#pragma once
// Helpers for tests that start real plexusd / plexus-names / plexus processes on loopback, or
// inside the hosts of a netns.hpp Network.
// Every process started here is killed when its handle goes out of scope, also when a test fails.
// Nothing here sleeps for a fixed time: waits poll a condition against a deadline.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../common/slowdown.hpp"  // slowdown(), slower(): the speed bounds of a slower build

namespace plexus::test {

using namespace std::chrono_literals;

class Host;  // netns.hpp

/// Paths of the built programs (set by CMake).
std::string plexusd_path();
std::string plexus_path();
std::string names_path();
/// The example monitors shipped in configs/monitors.
std::string monitors_dir();

/// A fresh directory, removed afterwards.
class TempDir {
public:
    TempDir();
    ~TempDir();
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::string& path() const { return path_; }
    std::string file(const std::string& name) const { return path_ + "/" + name; }

private:
    std::string path_;
};

/// Polls `condition` until it holds or `timeout` (stretched by slowdown()) passes; true if it held.
/// The deadline is only how long to wait for what must happen: waiting longer weakens no test.
bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 10s);

/// A child process with stdout and stderr sent to files; killed on destruction.
class Process {
public:
    Process(const std::vector<std::string>& argv, const std::map<std::string, std::string>& env,
            const std::string& log_prefix, const std::string& stdin_file = "");
    ~Process();
    Process(const Process&) = delete;
    Process& operator=(const Process&) = delete;
    Process(Process&& other) noexcept;

    pid_t pid() const { return pid_; }
    /// Waits for the exit; nullopt if still running after `timeout`. Exit code, or 128+signal.
    std::optional<int> wait(std::chrono::milliseconds timeout = 30s);
    bool running();
    void signal(int sig);
    std::string out() const;
    std::string err() const;

private:
    pid_t pid_ = -1;
    std::optional<int> status_;
    std::string out_path_;
    std::string err_path_;
};

/// Flags a plexusd or plexus-names needs to listen beyond loopback: --secret-file with the test
/// secret. A Daemon or NameServerProcess on a host gets them unless its `extra` has --insecure.
const std::vector<std::string>& beyond_loopback_flags();
/// The deployment secret of this test program's hosts (a 0600 file, removed at exit).
const std::string& test_secret_file();

/// Pass as `names` to make a daemon find its name server itself (no --names, no PLEXUS_NAMES): by
/// multicast discovery, inside a host of a Network only.
inline const std::string discover_names = "(discover)";

/// A plexusd, by default with its own embedded name server on a free port.
class Daemon {
public:
    /// names: "" to embed a name server on a free port; else the HOST:PORT of one to use.
    Daemon(const TempDir& dir, const std::string& node, const std::string& names = "",
           const std::vector<std::string>& extra = {});
    /// The same inside `host`, listening on its address (names "" embeds one there). The CLI
    /// helpers below run inside the daemon's host, as a component on that host would.
    Daemon(const TempDir& dir, const Host& host, const std::string& node, const std::string& names,
           const std::vector<std::string>& extra = {});
    /// The host it runs in; nullptr for this machine's loopback.
    const Host* host() const { return host_; }
    const std::string& socket() const { return socket_; }
    const std::string& names() const { return names_; }
    const std::string& address() const { return address_; }
    Process& process() { return *process_; }
    /// Starts the daemon again after its process ended (kill -9 it first): the same node, socket,
    /// listening address, name server and flags, as a supervisor restarting it would.
    void start_again();
    /// Resident memory of the daemon, in KiB (from /proc).
    long rss_kib() const;
    /// Environment that points the CLI at this daemon (and gives it the daemon's --identity).
    std::map<std::string, std::string> env() const;

private:
    void start(const TempDir& dir, const std::string& node, const std::string& names,
               const std::vector<std::string>& extra);
    void launch();

    const Host* host_ = nullptr;
    bool discovers_ = false;
    std::string identity_;  ///< its --identity, which CLIs on its host use too
    std::string node_;
    std::string ready_;
    std::string log_prefix_;
    std::vector<std::string> argv_;
    int starts_ = 0;
    std::string socket_;
    std::string names_;
    std::string address_;
    std::unique_ptr<Process> process_;
};

/// A plexus-names on a free port, on loopback or inside a host; killed on destruction.
class NameServerProcess {
public:
    explicit NameServerProcess(const TempDir& dir, const std::vector<std::string>& extra = {});
    NameServerProcess(const TempDir& dir, const Host& host, const std::vector<std::string>& extra = {});
    /// The HOST:PORT it serves on: what `--names` and PLEXUS_NAMES take.
    const std::string& address() const { return address_; }
    Process& process() { return *process_; }

private:
    void start(const TempDir& dir, const std::vector<std::string>& extra);

    const Host* host_ = nullptr;
    std::string address_;
    std::unique_ptr<Process> process_;
};

struct CliResult {
    int status = -1;
    std::string out;
    std::string err;
};

/// Runs `plexus args...` against a daemon, feeding `input` on stdin, and waits for it.
CliResult run_cli(const TempDir& dir, const Daemon& daemon, const std::vector<std::string>& args,
                  const std::string& input = "", std::chrono::milliseconds timeout = 60s);

/// Starts `plexus args...` in the background (for readers).
std::unique_ptr<Process> start_cli(const TempDir& dir, const Daemon& daemon,
                                   const std::vector<std::string>& args, const std::string& name);

/// `plexus write PORT` fed through a FIFO, so that lines can be sent while it runs: open the port,
/// connect it with any carrier, then send. finish() closes its stdin and waits for the exit.
class CliWriter {
public:
    CliWriter(const TempDir& dir, const Daemon& daemon, const std::string& port, const std::string& name);
    ~CliWriter();
    CliWriter(const CliWriter&) = delete;
    CliWriter& operator=(const CliWriter&) = delete;
    void send(const std::string& lines);
    /// Exit status (-1 if it did not exit in time).
    int finish(std::chrono::milliseconds timeout = 60s);
    Process& process() { return *process_; }

private:
    int fd_ = -1;
    std::unique_ptr<Process> process_;
};

/// Polls until `plexus exists PORT` succeeds on that daemon's name server.
bool wait_port(const TempDir& dir, const Daemon& daemon, const std::string& port);

/// "from\n" ... "from+count-1\n": numbered lines for `plexus write`, and what a reader prints of them.
std::string numbered_lines(int from, int count);
/// The bytes of message `i` of stream `stream`: a pattern of both, so that a message that arrives
/// changed, or out of place, or in another stream, is told apart.
void fill_stream_bytes(std::span<std::uint8_t> bytes, int stream, std::uint32_t i);

/// Exit status of a forked child (Host::fork_inside), or -1 (after killing it) if it is still
/// running at the deadline.
int wait_child(pid_t pid, std::chrono::milliseconds timeout = 20s);

/// `plexus stats PORT --json` on `daemon`: that port's entry, or null.
nlohmann::json port_stats(const TempDir& dir, const Daemon& daemon, const std::string& port);
/// The stats of the connection into `port` from `source` on `daemon`; null if there is none.
nlohmann::json inbound_stats(const TempDir& dir, const Daemon& daemon, const std::string& port,
                             const std::string& source);
/// The stats of the connection out of `port` to `destination` on `daemon`; null if there is none.
nlohmann::json outgoing_stats(const TempDir& dir, const Daemon& daemon, const std::string& port,
                              const std::string& destination);

/// One JSON value per complete, non-empty line (the output of `plexus read`).
std::vector<nlohmann::json> json_lines(const std::string& text);

/// Reads a whole file.
std::string read_file(const std::string& path);

}  // namespace plexus::test
