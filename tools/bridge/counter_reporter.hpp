#pragma once
// Sends each bridged port's counters to the daemon (Port::report) twice a second when they changed,
// so `plexus stats PORT` shows what the bridge passed on and dropped, and every 5 s anyway (a
// daemon that restarted has forgotten them).
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include <plexus/client.hpp>

#include "port_counters.hpp"

namespace plexus::bridge {

class CounterReporter {
public:
    static constexpr std::chrono::milliseconds period{500};

    CounterReporter() = default;
    /// Stops the thread.
    ~CounterReporter();
    CounterReporter(const CounterReporter&) = delete;
    CounterReporter& operator=(const CounterReporter&) = delete;

    /// Reports `counters` for `port`; both must outlive the reporter. Add every port before start().
    void add(Port& port, const PortCounters& counters);
    void start();
    /// Stops the thread (waiting for a report under way). Call it before the ports go away.
    void stop();

private:
    struct Entry {
        Port* port;
        const PortCounters* counters;
        Value last;
    };
    void report_changed();

    std::vector<Entry> entries_;
    std::mutex mutex_;
    std::condition_variable wake_;
    bool stopping_ = false;
    unsigned rounds_ = 0;
    std::thread thread_;
};

}  // namespace plexus::bridge
