#include "roudi_process.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <stdexcept>
#include <string>

#include "server_process.hpp"

namespace plexus::bench::peers {

namespace {

using namespace std::chrono_literals;

// Where iceoryx 2.0's RouDi takes its machine-wide lock (flock) while it runs.
constexpr const char* roudi_lock = "/tmp/iox-unique-roudi.lock";
// A previous run's RouDi is still removing its shared memory for a moment after that run's exit.
constexpr auto previous_roudi_wait = 10s;
constexpr auto start_timeout = 10s;
constexpr const char* ready_line = "RouDi is ready for clients";
constexpr const char* lock_taken_line = "is RouDi still running";

/// True while some process holds RouDi's lock.
bool roudi_lock_held() {
    const int fd = ::open(roudi_lock, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return false;  // no lock file: no RouDi
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);  // releases it, if it was ours for a moment
    return held;
}

[[noreturn]] void throw_already_running() {
    throw std::runtime_error(
        "iceoryx: a RouDi is already running on this machine (it holds " + std::string(roudi_lock) +
        "). The bench starts its own, with mempools sized for the run; stop the other one (e.g. "
        "`pgrep -a iox-roudi`) and run again");
}

void write_config(const std::string& path, std::size_t chunk_size, std::size_t chunk_count) {
    std::ofstream config(path, std::ios::trunc);
    // RouDi adds its chunk header (40 bytes in 2.0) to `size` itself: `size` is the payload.
    config << "[general]\nversion = 1\n\n[[segment]]\n\n[[segment.mempool]]\n"
           << "size = " << chunk_size << "\ncount = " << chunk_count << "\n";
    if (!config.flush())
        throw std::runtime_error("cannot write " + path);
}

}  // namespace

RoudiProcess::RoudiProcess(const TempDir& dir, std::size_t chunk_size, std::size_t chunk_count) {
    const std::string program = find_program("iox-roudi");
    if (program.empty())
        throw std::runtime_error(
            "iceoryx's RouDi (iox-roudi) is not installed: run scripts/bench-peers-setup");
    if (!poll_until([] { return !roudi_lock_held(); }, previous_roudi_wait))
        throw_already_running();
    const std::string config = dir.file("roudi.toml");
    write_config(config, chunk_size, chunk_count);
    const std::string log = dir.file("roudi.log");
    process_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{program, "--config-file", config, "--log-level", "warning"}, log);
    const bool ready = poll_until(
        [&] { return !process_->running() || read_file(log).find(ready_line) != std::string::npos; },
        start_timeout);
    if (ready && process_->running())
        return;
    const std::string output = process_->log_tail();
    if (output.find(lock_taken_line) != std::string::npos)
        throw_already_running();
    throw std::runtime_error("iceoryx: RouDi did not start:\n" + output);
}

RoudiProcess::~RoudiProcess() {
    // Not stopped here: RouDi would send this still-registered process SIGTERM and wait for it to
    // go (see the header). The handle is let go; RouDi stops when this process has exited.
    if (process_ && process_->running()) {
        ChildProcess* left_running = process_.release();
        (void)left_running;
    }
}

}  // namespace plexus::bench::peers
