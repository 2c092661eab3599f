#include "component_process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

extern char** environ;

namespace plexus::cli {

namespace {

using Clock = std::chrono::steady_clock;

std::string now_text() {
    const std::time_t now = std::time(nullptr);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S%z", std::localtime(&now));
    return text;
}

/// Whether any process of group `pgid` is left (zombies included: their parent will reap them).
bool group_exists(pid_t pgid) {
    return ::kill(-pgid, 0) == 0 || errno == EPERM;
}

}  // namespace

std::optional<unsigned long long> process_start_time(pid_t pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!in || !std::getline(in, line))
        return std::nullopt;
    // "PID (COMM) STATE ..." and COMM may hold spaces and parentheses: fields start after the last ')'.
    const auto close = line.rfind(')');
    if (close == std::string::npos)
        return std::nullopt;
    std::istringstream fields(line.substr(close + 1));
    std::string state;
    fields >> state;
    if (state == "Z" || state == "X")
        return std::nullopt;
    std::string field;
    for (int i = 4; i < 22 && fields >> field; ++i) {
    }
    unsigned long long start = 0;
    if (!(fields >> start))
        return std::nullopt;
    return start;
}

bool still_running(const ComponentRecord& record) {
    if (record.pid <= 0)
        return false;
    const auto start = process_start_time(record.pid);
    return start && *start == record.start_time;
}

proto::Result<ComponentRecord> start_process(const Launch& launch) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(launch.log).parent_path(), ec);
    const int log = ::open(launch.log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
    if (log < 0)
        return proto::Error{"cannot open the log file " + launch.log + ": " + std::strerror(errno)};
    std::string header = "--- " + now_text() + " plexus up: " + launch.program;
    for (const auto& arg : launch.args)
        header += " " + arg;
    header += "\n";
    (void)!::write(log, header.data(), header.size());
    const int null = ::open("/dev/null", O_RDONLY | O_CLOEXEC);

    // Everything the child needs is built before fork: between fork and exec only
    // async-signal-safe calls (this process has threads: the client library's).
    std::vector<std::string> argv_text{launch.program};
    argv_text.insert(argv_text.end(), launch.args.begin(), launch.args.end());
    std::vector<char*> argv;
    for (auto& arg : argv_text)
        argv.push_back(arg.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_text;
    for (char** e = environ; *e; ++e) {
        const std::string entry = *e;
        if (!launch.env.count(entry.substr(0, entry.find('='))))
            env_text.push_back(entry);
    }
    for (const auto& [key, value] : launch.env)
        env_text.push_back(key + "=" + value);
    std::vector<char*> envp;
    for (auto& entry : env_text)
        envp.push_back(entry.data());
    envp.push_back(nullptr);

    int report[2];
    if (::pipe2(report, O_CLOEXEC) != 0) {
        ::close(log);
        return proto::Error{std::string("pipe: ") + std::strerror(errno)};
    }
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int error = errno;
        ::close(log);
        ::close(report[0]);
        ::close(report[1]);
        return proto::Error{std::string("fork: ") + std::strerror(error)};
    }
    if (pid == 0) {
        ::setsid();
        if (null >= 0)
            ::dup2(null, STDIN_FILENO);
        ::dup2(log, STDOUT_FILENO);
        ::dup2(log, STDERR_FILENO);
        ::execve(argv[0], argv.data(), envp.data());
        const int error = errno;
        (void)!::write(report[1], &error, sizeof error);
        ::_exit(127);
    }
    ::close(report[1]);
    ::close(log);
    if (null >= 0)
        ::close(null);
    int error = 0;
    ssize_t got;
    do {
        got = ::read(report[0], &error, sizeof error);  // EOF: exec succeeded and closed the pipe
    } while (got < 0 && errno == EINTR);
    ::close(report[0]);
    if (got == sizeof error) {
        int status = 0;
        ::waitpid(pid, &status, 0);
        return proto::Error{"cannot execute " + launch.program + ": " + std::strerror(error)};
    }
    ComponentRecord record;
    record.pid = pid;
    record.start_time = process_start_time(pid).value_or(0);
    record.log = launch.log;
    record.started_at = now_text();
    return record;
}

std::optional<int> exited_child(pid_t pid) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) != pid)
        return std::nullopt;
    if (WIFEXITED(status))
        return WEXITSTATUS(status);
    return 128 + WTERMSIG(status);
}

std::vector<Stopped> stop_processes(const std::vector<ComponentRecord>& records,
                                    std::chrono::milliseconds grace) {
    std::vector<Stopped> result(records.size(), Stopped::gone);
    std::vector<bool> signalled(records.size(), false);
    for (std::size_t i = 0; i < records.size(); ++i) {
        if (!still_running(records[i]))
            continue;
        // The group: the component and whatever it started (it leads a session of its own).
        if (::kill(-records[i].pid, SIGTERM) != 0)
            ::kill(records[i].pid, SIGTERM);
        signalled[i] = true;
        result[i] = Stopped::terminated;
    }
    const auto deadline = Clock::now() + grace;
    auto pause = std::chrono::milliseconds(5);
    for (;;) {
        bool waiting = false;
        for (std::size_t i = 0; i < records.size(); ++i) {
            if (!signalled[i])
                continue;
            exited_child(records[i].pid);  // reaps our own children (an `up` undoing itself)
            waiting = waiting || still_running(records[i]);
        }
        if (!waiting || Clock::now() >= deadline)
            break;
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::milliseconds(100));
    }
    for (std::size_t i = 0; i < records.size(); ++i) {
        if (!signalled[i])
            continue;
        if (still_running(records[i])) {
            ::kill(-records[i].pid, SIGKILL);
            ::kill(records[i].pid, SIGKILL);
            result[i] = Stopped::killed;
        } else if (group_exists(records[i].pid)) {
            // The leader went; what it started in its group goes with it.
            ::kill(-records[i].pid, SIGKILL);
        }
        // Wait for the kill to land, so that "nothing left running" holds when we return.
        const auto killed_by = Clock::now() + std::chrono::seconds(2);
        while (still_running(records[i]) && Clock::now() < killed_by) {
            exited_child(records[i].pid);
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        exited_child(records[i].pid);
    }
    return result;
}

}  // namespace plexus::cli
