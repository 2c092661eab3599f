#include "ends.hpp"

#include <algorithm>
#include <cstring>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "dds_link.hpp"
#include "measurement.hpp"
#include "mqtt_link.hpp"

namespace plexus::bench::bridges {

namespace {

using Clock = std::chrono::steady_clock;

std::unique_ptr<Link> link_of(const EndOptions& options, bool keep_all) {
    if (options.link == "dds")
        return make_dds_link(options.out, options.in, keep_all);
    const auto colon = options.broker.rfind(':');
    return make_mqtt_link(options.broker.substr(0, colon), std::stoi(options.broker.substr(colon + 1)),
                          options.out, options.in, options.qos);
}

std::uint64_t number_of(const std::vector<std::uint8_t>& payload) {
    std::uint64_t number = 0;
    if (payload.size() >= sizeof number)
        std::memcpy(&number, payload.data(), sizeof number);
    return number;
}

void stamp(std::vector<std::uint8_t>& payload, std::uint64_t number) {
    std::memcpy(payload.data(), &number, sizeof number);
}

/// Waits until the whole path answers: the other ends have matched and passed one message through.
void wait_for_path(Link& link, std::vector<std::uint8_t>& payload) {
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    while (!link.ready()) {
        if (Clock::now() > deadline)
            throw std::runtime_error("the path's other ends never matched");
        std::this_thread::sleep_for(std::chrono::milliseconds(10));  // discovery: nothing to wait on
    }
    stamp(payload, 0);
    for (;;) {
        if (Clock::now() > deadline)
            throw std::runtime_error("nothing came back along the path");
        link.publish(payload);
        if (link.receive(std::chrono::milliseconds(200)))
            break;
    }
    while (link.receive(std::chrono::milliseconds(200))) {
    }
}

}  // namespace

int run_ping(const EndOptions& options) {
    std::vector<std::uint8_t> payload(std::max<std::size_t>(options.size, 8), 0x5a);
    auto link = link_of(options, false);
    wait_for_path(*link, payload);
    std::vector<double> half_rtt_us;
    std::size_t lost = 0;
    for (std::uint64_t number = 1; number <= options.count; ++number) {
        stamp(payload, number);
        const auto start = Clock::now();
        link->publish(payload);
        for (;;) {
            const auto back = link->receive(std::chrono::seconds(5));
            if (!back) {
                ++lost;
                break;
            }
            if (number_of(*back) == number) {
                half_rtt_us.push_back(
                    std::chrono::duration<double, std::micro>(Clock::now() - start).count() / 2);
                break;
            }
        }
    }
    std::sort(half_rtt_us.begin(), half_rtt_us.end());
    nlohmann::json out{{"p50_us", percentile(half_rtt_us, 0.5)},
                       {"p99_us", percentile(half_rtt_us, 0.99)},
                       {"round_trips", half_rtt_us.size()},
                       {"lost", lost}};

    if (options.stream > 0) {
        // A stream with at most `window` messages in flight: the rate the path sustains without
        // dropping (keep-last queues on the way would drop a stream that outran them).
        std::uint64_t sent = 0;
        std::uint64_t received = 0;
        const std::uint64_t first = 1'000'000'000;
        const auto start = Clock::now();
        bool stalled = false;
        while (received < options.stream && !stalled) {
            while (sent < options.stream && sent - received < options.window) {
                stamp(payload, first + sent++);
                link->publish(payload);
            }
            if (const auto back = link->receive(std::chrono::seconds(5)); !back)
                stalled = true;
            else if (number_of(*back) >= first)
                ++received;
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        out["stream_sent"] = sent;
        out["stream_received"] = received;
        out["stream_msgs_per_s"] = received / seconds;
        out["stream_stalled"] = stalled;
    }
    std::cout << out.dump() << std::endl;
    return 0;
}

int run_echo(const EndOptions& options) {
    auto link = link_of(options, false);
    for (;;) {
        if (auto payload = link->receive(std::chrono::seconds(1)))
            link->publish(*payload);
    }
}

}  // namespace plexus::bench::bridges
