// plexus-bench memory --burst: does plexusd give back what a drained burst took? Readers that
// stall (stopped processes) let their strict queues fill with one queue's worth of messages per
// stream; then every port closes. Prints the daemon's resident memory idle, at the peak, and as it
// falls afterwards (issue 26: 226 MiB kept for good after 50 streams of 4 KiB, idle 7 MiB).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "plexus/client.hpp"
#include "process_stats.hpp"
#include "run_deadline.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using Clock = std::chrono::steady_clock;

double mib(long kib) {
    return static_cast<double>(kib) / 1024;
}

/// A child process that opens the readers' ports and then stops itself: its queues fill in the
/// daemon, as those of a component that hangs. Returns its pid once the ports are open.
pid_t start_stalled_readers(const std::string& socket, std::size_t streams) {
    int ready[2];
    if (::pipe(ready) != 0)
        throw std::runtime_error("memory --burst: pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0)
        throw std::runtime_error("memory --burst: fork failed");
    if (pid == 0) {
        ::close(ready[0]);
        try {
            Client client(Client::Options{socket, std::chrono::milliseconds(10000)});
            std::vector<Port> ports;
            for (std::size_t i = 0; i < streams; ++i)
                ports.push_back(client.open("/bench/burst/in" + std::to_string(i)));
            const char byte = 1;
            if (::write(ready[1], &byte, 1) != 1)
                ::_exit(1);
            ::raise(SIGSTOP);
        } catch (...) {
            ::_exit(1);
        }
        ::_exit(0);
    }
    ::close(ready[1]);
    char byte = 0;
    const bool opened = ::read(ready[0], &byte, 1) == 1;
    ::close(ready[0]);
    if (!opened)
        throw std::runtime_error("memory --burst: the readers could not open their ports");
    return pid;
}

}  // namespace

int run_memory_burst(const Options& options) {
    TempDir dir;
    const auto topology = Topology::plexus(dir, options.plexusd, 1);
    const pid_t daemon = topology->pids().front();
    RunDeadline deadline;
    const std::size_t streams = options.ports;
    const std::size_t per_stream = options.capacity ? options.capacity : 1024;  // the daemon's default queue
    const long idle = rss_kib(daemon);

    const pid_t readers = start_stalled_readers(topology->near_socket(), streams);
    long peak = 0;
    {
        Client writer(Client::Options{topology->near_socket(), std::chrono::milliseconds(10000)});
        std::vector<Port> ports;
        for (std::size_t i = 0; i < streams; ++i) {
            const std::string name = "/bench/burst/out" + std::to_string(i);
            ports.push_back(writer.open(name));
            writer.connect(name, "/bench/burst/in" + std::to_string(i));
        }
        const Value payload = Value::binary(std::vector<std::uint8_t>(options.size, 7));
        for (std::size_t m = 0; m < per_stream; ++m) {
            for (auto& port : ports)
                port.write(payload, false);
        }
        for (auto& port : ports)
            port.flush();
        // The queues are full once the daemon stops growing: poll until two readings agree.
        long last = -1;
        for (peak = rss_kib(daemon); peak != last; peak = rss_kib(daemon)) {
            last = peak;
            std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a measuring interval
        }
    }
    ::kill(readers, SIGKILL);
    ::waitpid(readers, nullptr, 0);
    const auto closed = Clock::now();
    const long near_idle = idle + 16 * 1024;
    double back_after = -1;
    long at_one = -1;
    long at_five = -1;
    while (Clock::now() - closed < std::chrono::seconds(5)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        const long now = rss_kib(daemon);
        const double seconds = std::chrono::duration<double>(Clock::now() - closed).count();
        if (back_after < 0 && now < near_idle)
            back_after = seconds;
        if (at_one < 0 && seconds >= 1)
            at_one = now;
    }
    at_five = rss_kib(daemon);
    std::printf(
        "memory --burst: %zu streams of %zu messages of %zu B into stalled readers, then every port closed\n",
        streams, per_stream, options.size);
    std::printf("  plexusd RSS  idle %.1f MiB   peak %.1f MiB   1 s after %.1f MiB   5 s after %.1f MiB\n",
                mib(idle), mib(peak), mib(at_one), mib(at_five));
    if (back_after >= 0)
        std::printf("  back within 16 MiB of idle after %.1f s\n", back_after);
    else
        std::printf("  not back within 16 MiB of idle after 5 s\n");
    return 0;
}

}  // namespace plexus::bench
