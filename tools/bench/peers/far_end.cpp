#include "far_end.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace plexus::bench::peers {

namespace {

using Clock = std::chrono::steady_clock;

// As much as a pipe may hold without raising /proc/sys/fs/pipe-max-size (1 MiB by default): 32,768
// reports, so that a far subscriber does not wait for a measuring process busy elsewhere.
constexpr int fifo_capacity = 1 << 20;
constexpr std::size_t read_chunk = 64 * 1024;
constexpr std::size_t reports_per_write = 256;
constexpr auto longest_hold = std::chrono::milliseconds(1);     ///< of a report, before it is written
constexpr auto sigterm_check = std::chrono::milliseconds(100);  ///< how often a far end looks at SIGTERM

volatile sig_atomic_t stop_requested = 0;

void on_sigterm(int /*signal*/) {
    stop_requested = 1;
}

}  // namespace

std::vector<std::string> far_end_command(const std::string& self, const std::string& system) {
    return {self, "peer-far-end", "--system", system};
}

FarSubscriber::FarSubscriber(std::vector<std::string> command, const std::string& topic, const TempDir& dir)
    : buffer_(read_chunk) {
    static std::atomic<int> made{0};
    const std::string name = "far-subscriber-" + std::to_string(++made);
    const std::string fifo = dir.file(name + ".fifo");
    if (::mkfifo(fifo.c_str(), 0600) != 0)
        throw std::runtime_error("cannot make the FIFO " + fifo + ": " + std::strerror(errno));
    // Open before the far end does: a reader that does not block, so that the far end's open for
    // writing (which waits for a reader) returns at once.
    fifo_ = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fifo_ < 0)
        throw std::runtime_error("cannot open the FIFO " + fifo + ": " + std::strerror(errno));
    ::fcntl(fifo_, F_SETPIPE_SZ, fifo_capacity);  // a smaller pipe only costs the far end waits
    command.insert(command.end(), {"--role", "subscriber", "--topic", topic, "--report", fifo});
    try {
        process_ = std::make_unique<ChildProcess>(command, dir.file(name + ".log"));
    } catch (...) {
        ::close(fifo_);  // the destructor does not run for a constructor that throws
        throw;
    }
}

FarSubscriber::~FarSubscriber() {
    process_.reset();  // first: a far end blocked writing to a full FIFO sees SIGTERM, not a hang
    ::close(fifo_);
}

bool FarSubscriber::fill(std::chrono::milliseconds timeout) {
    if (begin_ > 0) {
        std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
        end_ -= begin_;
        begin_ = 0;
    }
    const auto deadline = Clock::now() + timeout;
    for (;;) {
        const ssize_t n = ::read(fifo_, buffer_.data() + end_, buffer_.size() - end_);
        if (n > 0) {
            end_ += static_cast<std::size_t>(n);
            return true;
        }
        if (n == 0 && process_->running()) {
            // No writer yet (the far end is starting) reads as end of file too: wait for one.
        } else if (n == 0) {
            throw std::runtime_error("the far subscriber exited:\n" + process_->log_tail());
        } else if (errno != EAGAIN && errno != EINTR) {
            throw std::runtime_error(std::string("cannot read a far subscriber's reports: ") +
                                     std::strerror(errno));
        }
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
        if (left.count() <= 0)
            return false;
        pollfd ready{fifo_, POLLIN, 0};
        const int polled = ::poll(&ready, 1, static_cast<int>(std::min<long>(left.count(), 100)));
        if (polled < 0 && errno != EINTR)
            throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
        if (polled > 0 && (ready.revents & POLLIN) == 0) {
            // POLLHUP without data: the far end closed the FIFO; the read above says how.
            if (!process_->running())
                throw std::runtime_error("the far subscriber exited:\n" + process_->log_tail());
        }
    }
}

bool FarSubscriber::receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (end_ - begin_ < sizeof(Report)) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
        if (!fill(std::max(left, std::chrono::milliseconds(0))))
            return false;
    }
    Report report;
    std::memcpy(&report, buffer_.data() + begin_, sizeof report);
    begin_ += sizeof report;
    arrival.stamp = report.stamp;
    arrival.arrived_ns = report.arrived_ns;
    return true;
}

bool FarSubscriber::receive(std::string& payload, std::chrono::milliseconds timeout) {
    Arrival arrival;
    if (!receive_stamp(arrival, timeout))
        return false;
    payload.assign(reinterpret_cast<const char*>(&arrival.stamp), sizeof arrival.stamp);
    return true;
}

namespace {

std::vector<std::string> echo_command(std::vector<std::string> command, const std::string& from,
                                      const std::string& to) {
    command.insert(command.end(), {"--role", "echo", "--topic", from, "--answer-topic", to});
    return command;
}

}  // namespace

FarEcho::FarEcho(std::vector<std::string> command, const std::string& from, const std::string& to,
                 const TempDir& dir)
    : process_(echo_command(std::move(command), from, to), dir.file("far-echo.log")) {}

ReportWriter::ReportWriter(const std::string& fifo) {
    // SIGPIPE would end the process at a write after the measuring process has gone; EPIPE
    // ends the loop instead.
    ::signal(SIGPIPE, SIG_IGN);
    fd_ = ::open(fifo.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd_ < 0)
        throw std::runtime_error("cannot open the report FIFO " + fifo + ": " + std::strerror(errno));
    pending_.reserve(4096);
}

ReportWriter::~ReportWriter() {
    ::close(fd_);
}

void ReportWriter::add(const Stamp& stamp, std::int64_t arrived_ns) {
    if (pending_.empty())
        oldest_ns_ = arrived_ns;
    pending_.push_back({stamp, arrived_ns});
}

NextWait ReportWriter::after_batch() {
    if (pending_.empty())
        return sigterm_check;
    const auto held = std::chrono::nanoseconds(steady_ns() - oldest_ns_);
    if (pending_.size() < reports_per_write && held < longest_hold)
        return std::chrono::ceil<std::chrono::milliseconds>(longest_hold - held);
    if (!flush())
        return std::nullopt;
    return sigterm_check;
}

NextWait keep_waiting() {
    return sigterm_check;
}

bool ReportWriter::flush() {
    const char* next = reinterpret_cast<const char*>(pending_.data());
    std::size_t left = pending_.size() * sizeof(Report);
    pending_.clear();
    while (left > 0) {
        const ssize_t n = ::write(fd_, next, left);
        if (n > 0) {
            next += n;
            left -= static_cast<std::size_t>(n);
        } else if (n < 0 && errno == EINTR && !far_end_stopping()) {
            continue;
        } else {
            return false;
        }
    }
    return true;
}

void stop_far_end_on_sigterm() {
    struct sigaction action {};
    action.sa_handler = on_sigterm;
    sigemptyset(&action.sa_mask);
    action.sa_flags = 0;  // no SA_RESTART: a write blocked on a full FIFO returns EINTR
    ::sigaction(SIGTERM, &action, nullptr);
    ::sigaction(SIGINT, &action, nullptr);
}

bool far_end_stopping() {
    return stop_requested != 0;
}

}  // namespace plexus::bench::peers
