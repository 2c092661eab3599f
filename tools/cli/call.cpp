// `plexus call` and `plexus serve`: request/reply from the command line (docs/CALLS.md).
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <pthread.h>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <thread>

#include "commands.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::cli {

namespace {

/// A command line argument as a value: JSON if it parses, else the text itself (as `write` takes lines).
Value value_of(const std::string& text) {
    Value value = Value::parse(text, nullptr, false);
    if (value.is_discarded())
        value = text;
    return value;
}

/// What a process wrote to a descriptor, until it closed it.
std::string read_all(int fd) {
    std::string out;
    char buffer[4096];
    for (;;) {
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n > 0) {
            out.append(buffer, static_cast<std::size_t>(n));
            continue;
        }
        if (n < 0 && errno == EINTR)
            continue;
        return out;
    }
}

/// Runs `sh -c command` with `input` on its standard input; its standard output, or an Error with
/// its standard error and exit status when it fails.
std::string run_command(const std::string& command, const std::string& input) {
    int in[2], out[2], err[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0)
        throw Error(ErrorCode::refused, std::string("pipe: ") + std::strerror(errno));
    const pid_t pid = ::fork();
    if (pid < 0)
        throw Error(ErrorCode::refused, std::string("fork: ") + std::strerror(errno));
    if (pid == 0) {
        ::dup2(in[0], STDIN_FILENO);
        ::dup2(out[1], STDOUT_FILENO);
        ::dup2(err[1], STDERR_FILENO);
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    ::close(in[0]);
    ::close(out[1]);
    ::close(err[1]);
    // The request goes in on a thread of its own: a command that writes much before it reads would
    // otherwise block against us.
    std::thread feeder([fd = in[1], input] {
        std::size_t done = 0;
        while (done < input.size()) {
            const ssize_t n = ::write(fd, input.data() + done, input.size() - done);
            if (n < 0 && errno == EINTR)
                continue;
            if (n <= 0)
                break;  // the command closed its input: it wants no more
            done += static_cast<std::size_t>(n);
        }
        ::close(fd);
    });
    std::string error_text;
    std::thread error_reader([&] { error_text = read_all(err[0]); });
    std::string output = read_all(out[0]);
    feeder.join();
    error_reader.join();
    ::close(out[0]);
    ::close(err[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::string why = WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                            : "signal " + std::to_string(WTERMSIG(status));
        while (!error_text.empty() && (error_text.back() == '\n' || error_text.back() == '\r'))
            error_text.pop_back();
        throw std::runtime_error("`" + command + "` failed (" + why + ")" +
                                 (error_text.empty() ? "" : ": " + error_text));
    }
    return output;
}

}  // namespace

int call(const Common& common, const CallOptions& options) {
    if (auto error = proto::port_name_error(options.port))
        throw Error(ErrorCode::usage, *error);
    plexus::Client client({common.socket});
    const auto timeout = std::chrono::milliseconds(static_cast<std::int64_t>(options.timeout * 1000.0 + 0.5));
    const Received reply = client.request(options.port, value_of(options.value), timeout);
    std::cout << reply.data.dump(-1, ' ', false, Value::error_handler_t::replace) << std::endl;
    return 0;
}

int serve(const Common& common, const ServeOptions& options) {
    if (auto error = proto::port_name_error(options.port))
        throw Error(ErrorCode::usage, *error);
    if (options.echo == !options.exec.empty())
        throw Error(ErrorCode::usage, "say how to answer: --echo, or --exec CMD (one of them)");
    // SIGINT and SIGTERM are taken by sigwait below: blocked before any thread starts (the client's,
    // the service's), so that every thread inherits the mask and none is killed by them.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    ::pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
    std::signal(SIGPIPE, SIG_IGN);  // a command that closes its input early must not end us
    plexus::Client client({common.socket});
    std::function<Value(const Received&)> handler;
    if (options.echo) {
        handler = [](const Received& request) { return request.data; };
    } else {
        handler = [command = options.exec](const Received& request) {
            std::string output = run_command(command, request.data.dump() + "\n");
            while (!output.empty() && (output.back() == '\n' || output.back() == '\r'))
                output.pop_back();
            return value_of(output);
        };
    }
    auto service = client.serve(options.port, handler);
    if (::isatty(STDERR_FILENO) != 0) {
        std::cerr << "plexus: serving " << options.port << " ("
                  << (options.echo ? "echo" : "answers with the output of `" + options.exec + "`")
                  << "); Ctrl-C to stop\n";
    }
    int signal_number = 0;
    ::sigwait(&stop_signals, &signal_number);
    return 0;
}

}  // namespace plexus::cli
