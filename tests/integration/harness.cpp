#include "harness.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "netns.hpp"

namespace plexus::test {

std::string plexusd_path() {
    return PLEXUSD_PATH;
}
std::string plexus_path() {
    return PLEXUS_CLI_PATH;
}
std::string names_path() {
    return PLEXUS_NAMES_PATH;
}

std::string monitors_dir() {
    return PLEXUS_MONITORS_DIR;
}

TempDir::TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "plexus-test-XXXXXX").string();
    if (!::mkdtemp(pattern.data()))
        throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
}

TempDir::~TempDir() {
    // PLEXUS_KEEP_TEST_DIRS=1 keeps the logs of the processes for a look after a failure.
    if (const char* keep = std::getenv("PLEXUS_KEEP_TEST_DIRS"); keep && std::string(keep) == "1") {
        std::fprintf(stderr, "kept %s\n", path_.c_str());
        return;
    }
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
}

bool eventually(const std::function<bool()>& condition, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + slower(timeout);
    auto pause = std::chrono::milliseconds(1);
    while (std::chrono::steady_clock::now() < deadline) {
        if (condition())
            return true;
        std::this_thread::sleep_for(pause);  // polling interval, not a wait for an outcome
        pause = std::min(pause * 2, std::chrono::milliseconds(50));
    }
    return condition();
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream content;
    content << in.rdbuf();
    return content.str();
}

Process::Process(const std::vector<std::string>& argv, const std::map<std::string, std::string>& env,
                 const std::string& log_prefix, const std::string& stdin_file)
    : out_path_(log_prefix + ".out"), err_path_(log_prefix + ".err") {
    pid_ = ::fork();
    if (pid_ < 0)
        throw std::runtime_error("fork failed");
    if (pid_ == 0) {
        ::setpgid(0, 0);
        const int in = ::open(stdin_file.empty() ? "/dev/null" : stdin_file.c_str(), O_RDONLY);
        const int out = ::open(out_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int err = ::open(err_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(in, 0);
        ::dup2(out, 1);
        ::dup2(err, 2);
        for (const auto& [key, value] : env)
            ::setenv(key.c_str(), value.c_str(), 1);
        std::vector<char*> args;
        for (const auto& a : argv)
            args.push_back(const_cast<char*>(a.c_str()));
        args.push_back(nullptr);
        ::execv(args[0], args.data());
        ::_exit(127);
    }
}

Process::Process(Process&& other) noexcept
    : pid_(other.pid_), status_(other.status_), out_path_(other.out_path_), err_path_(other.err_path_) {
    other.pid_ = -1;
}

Process::~Process() {
    if (pid_ <= 0 || status_)
        return;
    ::kill(pid_, SIGTERM);
    if (!wait(5s)) {
        ::kill(pid_, SIGKILL);
        wait(5s);
    }
}

std::optional<int> Process::wait(std::chrono::milliseconds timeout) {
    if (status_)
        return status_;
    eventually(
        [&] {
            int raw = 0;
            const pid_t done = ::waitpid(pid_, &raw, WNOHANG);
            if (done == pid_)
                status_ = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
            return status_.has_value();
        },
        timeout);
    return status_;
}

bool Process::running() {
    return !wait(0ms).has_value();
}

void Process::signal(int sig) {
    if (!status_)
        ::kill(pid_, sig);
}

std::string Process::out() const {
    return read_file(out_path_);
}
std::string Process::err() const {
    return read_file(err_path_);
}

namespace {

/// argv as it runs in `host`: inside its namespace, or as it is on this machine's loopback.
std::vector<std::string> placed(const Host* host, const std::vector<std::string>& argv) {
    return host ? host->wrap(argv) : argv;
}

/// Where a server in `host` listens: on the host's address there, on loopback here.
std::string any_port(const Host* host) {
    return (host ? host->address() : "127.0.0.1") + ":0";
}

}  // namespace

const std::string& test_secret_file() {
    // One secret for every host of this test program, in a file only its owner may read (as the
    // daemons demand); removed when the program exits.
    static const std::string path = [] {
        std::string pattern = (std::filesystem::temp_directory_path() / "plexus-secret-XXXXXX").string();
        const int fd = ::mkstemp(pattern.data());
        if (fd < 0)
            throw std::runtime_error("mkstemp failed for the test secret");
        const std::string secret = "test-deployment-secret-" + std::to_string(::getpid()) + "-0123456789";
        if (::write(fd, secret.data(), secret.size()) != static_cast<ssize_t>(secret.size()))
            throw std::runtime_error("cannot write the test secret");
        ::close(fd);
        static const std::string remove_at_exit = pattern;
        std::atexit([] { std::filesystem::remove(remove_at_exit); });
        return pattern;
    }();
    return path;
}

namespace {
/// What a server needs before it may listen on a host's address, so every multi-host test follows:
/// the deployment secret, unless the test asks for `--insecure` in `extra` (and then it has none).
std::vector<std::string> beyond_loopback(const std::vector<std::string>& extra) {
    std::vector<std::string> all;
    if (std::find(extra.begin(), extra.end(), "--insecure") == extra.end())
        all = beyond_loopback_flags();
    all.insert(all.end(), extra.begin(), extra.end());
    return all;
}
}  // namespace

const std::vector<std::string>& beyond_loopback_flags() {
    static const std::vector<std::string> flags{"--secret-file", test_secret_file()};
    return flags;
}

Daemon::Daemon(const TempDir& dir, const std::string& node, const std::string& names,
               const std::vector<std::string>& extra)
    : socket_(dir.file(node + ".sock")) {
    start(dir, node, names, extra);
}

Daemon::Daemon(const TempDir& dir, const Host& host, const std::string& node, const std::string& names,
               const std::vector<std::string>& extra)
    : host_(&host), socket_(dir.file(node + ".sock")) {
    start(dir, node, names, beyond_loopback(extra));
}

void Daemon::start(const TempDir& dir, const std::string& node, const std::string& names,
                   const std::vector<std::string>& extra) {
    node_ = node;
    ready_ = dir.file(node + ".ready");
    log_prefix_ = dir.file(node);
    argv_ = {plexusd_path(),  "--node",       node,   "--socket",    socket_, "--listen",
             any_port(host_), "--ready-file", ready_, "--log-level", "debug"};
    if (names.empty()) {
        argv_.insert(argv_.end(), {"--embedded-names", "--names", any_port(host_)});
    } else if (names == discover_names) {
        discovers_ = true;
    } else {
        argv_.insert(argv_.end(), {"--names", names});
    }
    argv_.insert(argv_.end(), extra.begin(), extra.end());
    if (const auto flag = std::find(extra.begin(), extra.end(), "--identity");
        flag != extra.end() && flag + 1 != extra.end())
        identity_ = *(flag + 1);
    // PLEXUS_TEST_THREADS=N runs every daemon of a test with --threads N (unless the test chose):
    // the suites of tests/integration/CMakeLists.txt that run again on several data threads.
    if (const char* threads = std::getenv("PLEXUS_TEST_THREADS");
        threads && std::find(extra.begin(), extra.end(), "--threads") == extra.end()) {
        argv_.insert(argv_.end(), {"--threads", threads});
    }
    launch();
    auto info = nlohmann::json::parse(read_file(ready_));
    names_ = info.at("names");
    address_ = info.at("address");
    // From now on the same addresses, not new free ports: a restarted daemon is found where the
    // first one was.
    for (std::size_t i = 0; i + 1 < argv_.size(); ++i) {
        if (argv_[i] == "--listen")
            argv_[i + 1] = address_;
        else if (argv_[i] == "--names" && names.empty())
            argv_[i + 1] = names_;
    }
}

void Daemon::launch() {
    std::filesystem::remove(ready_);
    const std::string log = starts_++ == 0 ? log_prefix_ : log_prefix_ + "-" + std::to_string(starts_);
    process_ = std::make_unique<Process>(placed(host_, argv_), std::map<std::string, std::string>{}, log);
    if (!eventually([&] { return std::filesystem::exists(ready_) || !process_->running(); }, 20s) ||
        !std::filesystem::exists(ready_)) {
        throw std::runtime_error("plexusd " + node_ + " did not become ready: " + process_->err());
    }
}

void Daemon::start_again() {
    if (process_->running()) {
        process_->signal(SIGKILL);
        process_->wait(10s);
    }
    launch();
}

long Daemon::rss_kib() const {
    std::ifstream status("/proc/" + std::to_string(process_->pid()) + "/status");
    std::string line;
    while (std::getline(status, line)) {
        if (line.rfind("VmRSS:", 0) == 0)
            return std::stol(line.substr(6));
    }
    return -1;
}

std::map<std::string, std::string> Daemon::env() const {
    std::map<std::string, std::string> env{{"PLEXUS_SOCKET", socket_}};
    if (!discovers_)
        env["PLEXUS_NAMES"] = names_;  // else the CLI finds the name server as its daemon did
    if (host_)
        env["PLEXUS_SECRET_FILE"] = test_secret_file();  // a CLI on a host holds the secret too
    if (!identity_.empty())
        env["PLEXUS_IDENTITY"] = identity_;  // and acts as the daemon's node
    return env;
}

NameServerProcess::NameServerProcess(const TempDir& dir, const std::vector<std::string>& extra) {
    start(dir, extra);
}

NameServerProcess::NameServerProcess(const TempDir& dir, const Host& host,
                                     const std::vector<std::string>& extra)
    : host_(&host) {
    start(dir, beyond_loopback(extra));
}

void NameServerProcess::start(const TempDir& dir, const std::vector<std::string>& extra) {
    static std::atomic<int> counter{0};
    const std::string name = "names" + std::to_string(counter++);
    const std::string ready = dir.file(name + ".ready");
    std::vector<std::string> argv{names_path(), "--listen", any_port(host_), "--ready-file", ready};
    argv.insert(argv.end(), extra.begin(), extra.end());
    process_ =
        std::make_unique<Process>(placed(host_, argv), std::map<std::string, std::string>{}, dir.file(name));
    if (!eventually([&] { return std::filesystem::exists(ready) || !process_->running(); }, 20s) ||
        !std::filesystem::exists(ready)) {
        throw std::runtime_error("plexus-names did not become ready: " + process_->err());
    }
    address_ = nlohmann::json::parse(read_file(ready)).at("names");
}

CliResult run_cli(const TempDir& dir, const Daemon& daemon, const std::vector<std::string>& args,
                  const std::string& input, std::chrono::milliseconds timeout) {
    static std::atomic<int> counter{0};
    const std::string name = "cli" + std::to_string(counter++);
    const std::string input_file = dir.file(name + ".in");
    {
        std::ofstream in(input_file, std::ios::binary);
        in << input;
    }
    std::vector<std::string> argv{plexus_path()};
    argv.insert(argv.end(), args.begin(), args.end());
    Process process(placed(daemon.host(), argv), daemon.env(), dir.file(name), input_file);
    auto status = process.wait(timeout);
    return {status.value_or(-1), process.out(), process.err()};
}

std::unique_ptr<Process> start_cli(const TempDir& dir, const Daemon& daemon,
                                   const std::vector<std::string>& args, const std::string& name) {
    std::vector<std::string> argv{plexus_path()};
    argv.insert(argv.end(), args.begin(), args.end());
    return std::make_unique<Process>(placed(daemon.host(), argv), daemon.env(), dir.file(name));
}

CliWriter::CliWriter(const TempDir& dir, const Daemon& daemon, const std::string& port,
                     const std::string& name) {
    const std::string fifo = dir.file(name + ".fifo");
    if (::mkfifo(fifo.c_str(), 0600) != 0)
        throw std::runtime_error("mkfifo " + fifo + " failed");
    process_ = std::make_unique<Process>(placed(daemon.host(), {plexus_path(), "write", port}), daemon.env(),
                                         dir.file(name), fifo);
    // Blocks until the child opens its end, which it does right after fork.
    fd_ = ::open(fifo.c_str(), O_WRONLY | O_CLOEXEC);  // later children must not hold it open
    if (fd_ < 0)
        throw std::runtime_error("cannot open " + fifo);
}

CliWriter::~CliWriter() {
    if (fd_ >= 0)
        ::close(fd_);
}

void CliWriter::send(const std::string& lines) {
    std::size_t sent = 0;
    while (sent < lines.size()) {
        const ssize_t n = ::write(fd_, lines.data() + sent, lines.size() - sent);
        if (n <= 0)
            throw std::runtime_error("the writer process stopped reading its stdin");
        sent += static_cast<std::size_t>(n);
    }
}

int CliWriter::finish(std::chrono::milliseconds timeout) {
    if (fd_ >= 0)
        ::close(fd_);
    fd_ = -1;
    return process_->wait(timeout).value_or(-1);
}

bool wait_port(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    return run_cli(dir, daemon, {"wait", port, "--timeout", "20"}).status == 0;
}

std::vector<nlohmann::json> json_lines(const std::string& text) {
    std::vector<nlohmann::json> lines;
    // Only complete lines: a reader that is still running may be half-way through one.
    std::size_t start = 0;
    for (std::size_t end = text.find('\n'); end != std::string::npos; end = text.find('\n', start)) {
        if (end > start) {
            const std::string line = text.substr(start, end - start);
            try {
                lines.push_back(nlohmann::json::parse(line));
            } catch (const std::exception& e) {
                throw std::runtime_error("not a JSON line: '" + line + "' (" + std::to_string(line.size()) +
                                         " bytes): " + e.what());
            }
        }
        start = end + 1;
    }
    return lines;
}

void fill_stream_bytes(std::span<std::uint8_t> bytes, int stream, std::uint32_t i) {
    std::uint32_t x = static_cast<std::uint32_t>(stream) * 7919u + i * 2654435761u + 1;
    for (auto& b : bytes) {
        x = x * 1664525u + 1013904223u;
        b = static_cast<std::uint8_t>(x >> 24);
    }
}

std::string numbered_lines(int from, int count) {
    std::string lines;
    for (int i = from; i < from + count; ++i)
        lines += std::to_string(i) + "\n";
    return lines;
}

/// Exit status of a forked child, or -1 (after killing it) if it is still running at the deadline.
int wait_child(pid_t pid, std::chrono::milliseconds timeout) {
    int status = -1;
    const bool done = eventually(
        [&] {
            int raw = 0;
            if (::waitpid(pid, &raw, WNOHANG) != pid)
                return false;
            status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
            return true;
        },
        timeout);
    if (!done) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
    }
    return status;
}

nlohmann::json port_stats(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    auto stats = run_cli(dir, daemon, {"stats", port, "--json"});
    if (stats.status != 0)
        return nullptr;
    const auto parsed = nlohmann::json::parse(stats.out);  // named: a temporary would dangle in the loop
    for (const auto& p : parsed["ports"]) {
        if (p["name"] == port)
            return p;
    }
    return nullptr;
}

namespace {
/// The entry of `port`'s `side` ("inbound" or "outgoing") whose `key` is `value`; null if none.
nlohmann::json connection_stats(const TempDir& dir, const Daemon& daemon, const std::string& port,
                                const char* side, const char* key, const std::string& value) {
    const auto p = port_stats(dir, daemon, port);
    if (p.is_null())
        return nullptr;
    for (const auto& entry : p[side]) {
        if (entry[key] == value)
            return entry;
    }
    return nullptr;
}
}  // namespace

nlohmann::json inbound_stats(const TempDir& dir, const Daemon& daemon, const std::string& port,
                             const std::string& source) {
    return connection_stats(dir, daemon, port, "inbound", "source", source);
}

nlohmann::json outgoing_stats(const TempDir& dir, const Daemon& daemon, const std::string& port,
                              const std::string& destination) {
    return connection_stats(dir, daemon, port, "outgoing", "destination", destination);
}

}  // namespace plexus::test
