#include "counter_reporter.hpp"

#include <spdlog/spdlog.h>

namespace plexus::bridge {

CounterReporter::~CounterReporter() {
    stop();
}

void CounterReporter::stop() {
    if (!thread_.joinable())
        return;
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    thread_.join();
}

void CounterReporter::add(Port& port, const PortCounters& counters) {
    entries_.push_back({&port, &counters, Value()});
}

void CounterReporter::start() {
    thread_ = std::thread([this] {
        std::unique_lock lock(mutex_);
        while (!stopping_) {
            if (wake_.wait_for(lock, period, [this] { return stopping_; }))
                break;  // the ports may be going away: no report after stop()
            lock.unlock();
            report_changed();
            lock.lock();
        }
    });
}

void CounterReporter::report_changed() {
    // Unchanged counters are sent again every tenth round: a daemon that restarted meanwhile has
    // the port opened again with nothing reported.
    const bool refresh = ++rounds_ % 10 == 0;
    for (auto& entry : entries_) {
        auto now = entry.counters->snapshot();
        if (now == entry.last && !refresh)
            continue;
        try {
            // False while the daemon is away: the port opened again starts with nothing reported,
            // so the next round reports again.
            if (entry.port->report(now))
                entry.last = std::move(now);
        } catch (const Error& error) {
            spdlog::debug("reporting the counters of {}: {}", entry.port->name(), error.what());
        }
    }
}

}  // namespace plexus::bridge
