#pragma once
// What a bridge did with the messages of one of its Plexus ports: how many it passed on, and how
// many it could not, by reason ("not_converted", "not_delivered", "own_message", ...). Each reason
// is logged once, with the first message's detail, then only counted — a broken publisher sends
// hundreds a second. The counts reach `plexus stats` through Port::report (CounterReporter).
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include <plexus/client.hpp>

namespace plexus::bridge {

class PortCounters {
public:
    /// `port` names the Plexus port; `peer` what it is bridged to ("rt/chatter", "mqtt a/+/b").
    PortCounters(std::string port, std::string peer);

    void passed() { passed_.fetch_add(1, std::memory_order_relaxed); }
    /// One message not passed on, for `reason` (a counter name); `detail` is logged the first time.
    void dropped(const std::string& reason, const std::string& detail);

    const std::string& port() const { return port_; }
    std::uint64_t passed_count() const { return passed_.load(std::memory_order_relaxed); }
    std::uint64_t dropped_count(const std::string& reason) const;
    /// {"passed": N, REASON: N, ...}: what Port::report sends.
    Value snapshot() const;

private:
    std::string port_;
    std::string peer_;
    std::atomic<std::uint64_t> passed_{0};
    mutable std::mutex mutex_;
    std::map<std::string, std::uint64_t> dropped_;
};

}  // namespace plexus::bridge
