#include "run_program.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <stdexcept>

namespace plexus::test {

namespace {

using Clock = std::chrono::steady_clock;

/// Owns a child: a child still running when this goes away (a failed assertion, an exception)
/// is killed and reaped.
class Child {
public:
    explicit Child(pid_t pid) : pid_(pid) {}
    ~Child() {
        if (pid_ > 0) {
            ::kill(pid_, SIGKILL);
            ::waitpid(pid_, nullptr, 0);
        }
    }
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;

    /// Exit code (128 + signal for a signal) once it has exited, or nullopt if it has not yet.
    std::optional<int> poll_exit() {
        int raw = 0;
        if (::waitpid(pid_, &raw, WNOHANG) != pid_)
            return std::nullopt;
        pid_ = -1;
        return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    }

private:
    pid_t pid_;
};

}  // namespace

ProgramResult run_program(const std::vector<std::string>& argv, std::chrono::milliseconds deadline) {
    int err_pipe[2];
    if (::pipe2(err_pipe, O_CLOEXEC) != 0)
        throw std::runtime_error("pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0)
        throw std::runtime_error("fork failed");
    if (pid == 0) {
        const int null = ::open("/dev/null", O_RDWR);
        ::dup2(null, STDIN_FILENO);
        ::dup2(null, STDOUT_FILENO);
        ::dup2(err_pipe[1], STDERR_FILENO);
        std::vector<char*> args;
        for (const auto& arg : argv)
            args.push_back(const_cast<char*>(arg.c_str()));
        args.push_back(nullptr);
        ::execv(args[0], args.data());
        ::_exit(127);
    }
    Child child(pid);
    ::close(err_pipe[1]);
    ProgramResult result;
    const auto end = Clock::now() + deadline;
    // Read stderr until the child closes it (it exits) or the deadline passes.
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
        if (left.count() <= 0)
            break;
        pollfd in{err_pipe[0], POLLIN, 0};
        if (::poll(&in, 1, static_cast<int>(left.count())) <= 0)
            continue;
        char buffer[4096];
        const ssize_t got = ::read(err_pipe[0], buffer, sizeof buffer);
        if (got <= 0)
            break;
        result.err.append(buffer, static_cast<std::size_t>(got));
    }
    ::close(err_pipe[0]);
    // The pipe closes as the child exits; wait for the exit itself within the same deadline.
    while (!(result.exit_code = child.poll_exit()) && Clock::now() < end) {
        pollfd none{-1, 0, 0};
        ::poll(&none, 0, 5);
    }
    return result;  // a child still running is killed as `child` goes away
}

}  // namespace plexus::test
