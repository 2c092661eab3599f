// plexus-sim-explorer: looks around at random. Publishes a point {"x": r cos a, "y": r sin a}
// (r = 0.8, a uniform in [-1.2, 1.2]) at --rate per real second, and picks a new one every --hold
// sim seconds (--hold / --speed real seconds). Knows nothing of the task.
#include <chrono>
#include <cmath>
#include <iostream>
#include <random>
#include <thread>

#include <CLI/CLI.hpp>

#include "plexus/client.hpp"
#include "stop_signal.hpp"

namespace {

constexpr double radius = 0.8;
constexpr double angle_limit = 1.2;

}  // namespace

int main(int argc, char** argv) {
    std::string out = "/explorer/out";
    double rate = 20;
    double hold = 1.5;
    std::uint64_t seed = 1;
    double speed = 1;
    CLI::App app{"plexus-sim-explorer: publishes random points to look at, each held for a while."};
    app.add_option("--out", out, "output port: {\"x\",\"y\"}")->capture_default_str();
    app.add_option("--rate", rate, "messages per real second")
        ->check(CLI::Range(0.1, 10000.0))
        ->capture_default_str();
    app.add_option("--hold", hold, "sim seconds before a new point")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    app.add_option("--seed", seed, "random seed")->capture_default_str();
    app.add_option("--speed", speed, "sim seconds per real second (as the world's)")
        ->check(CLI::Range(0.01, 1000.0))
        ->capture_default_str();
    CLI11_PARSE(app, argc, argv);

    plexus::sim::install_stop_handlers();
    try {
        plexus::Client client;
        plexus::Port port = client.open(out);
        std::mt19937_64 random(seed);
        std::uniform_real_distribution<double> angles(-angle_limit, angle_limit);
        using Clock = std::chrono::steady_clock;
        const auto period =
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
        const auto hold_for =
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(hold / speed));
        auto next = Clock::now();
        auto change_at = next;
        plexus::Value point;
        while (!plexus::sim::stop_requested()) {
            const auto now = Clock::now();
            if (now >= change_at) {
                const double a = angles(random);
                point = plexus::Value{{"x", radius * std::cos(a)}, {"y", radius * std::sin(a)}};
                change_at = now + hold_for;
            }
            port.write(point);
            next += period;
            // A machine that fell behind skips the missed messages instead of sending them in a burst.
            if (next < now)
                next = now;
            // Sleep in slices of at most 100 ms so that a low rate still stops promptly.
            while (!plexus::sim::stop_requested() && Clock::now() < next)
                std::this_thread::sleep_until(std::min(next, Clock::now() + std::chrono::milliseconds(100)));
        }
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-sim-explorer: " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
    return 0;
}
