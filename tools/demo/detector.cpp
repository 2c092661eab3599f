// plexus-detector: a simulated detector for the arbitration demo (scripts/run). It streams
// detections -- a position and a certainty -- while its target is "seen", and nothing while it
// is "gone", in a cycle, like a face or object detector looking at a scene that changes.
//
//     plexus-detector /demo/face/out --kind face --seen 6 --gone 4
//
// Each detection: {"kind":"face","x":0.41,"y":-0.12,"certainty":0.87,"n":17}.
#include <chrono>
#include <cmath>
#include <csignal>
#include <iostream>
#include <random>
#include <thread>

#include <CLI/CLI.hpp>

#include "plexus/client.hpp"

namespace {

volatile std::sig_atomic_t stop_requested = 0;

void request_stop(int) {
    stop_requested = 1;
}

struct Options {
    std::string port;
    std::string kind = "object";
    double rate = 20;   ///< detections per second while seen
    double seen = 6;    ///< seconds the target is in view
    double gone = 4;    ///< seconds it is out of view
    double offset = 0;  ///< seconds into the cycle to start at
    double low = 0.3;   ///< certainty range while seen
    double high = 0.95;
    unsigned seed = 1;
};

}  // namespace

int main(int argc, char** argv) {
    Options options;
    CLI::App app{
        "plexus-detector: streams simulated detections (position + certainty) on a port, "
        "in a cycle of seen / gone, for the arbitration demo."};
    app.add_option("PORT", options.port, "port to open and write on")->required();
    app.add_option("--kind", options.kind, "what it detects (goes into every detection)")
        ->capture_default_str();
    app.add_option("--rate", options.rate, "detections per second while seen")
        ->check(CLI::Range(0.1, 10000.0))
        ->capture_default_str();
    app.add_option("--seen", options.seen, "seconds in view per cycle")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    app.add_option("--gone", options.gone, "seconds out of view per cycle (0: always seen)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    app.add_option("--offset", options.offset, "seconds into the cycle to start at")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    app.add_option("--low", options.low, "lowest certainty while seen")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--high", options.high, "highest certainty while seen")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--seed", options.seed, "random seed")->capture_default_str();
    CLI11_PARSE(app, argc, argv);

    std::signal(SIGINT, request_stop);
    std::signal(SIGTERM, request_stop);
    try {
        plexus::Client client;
        auto port = client.open(options.port);
        std::mt19937 random(options.seed);
        std::uniform_real_distribution<double> jitter(-0.02, 0.02);
        std::uniform_real_distribution<double> certainty(options.low, options.high);
        const auto start = std::chrono::steady_clock::now();
        const auto period = std::chrono::duration<double>(1.0 / options.rate);
        const double cycle = options.seen + options.gone;
        double x = 0;
        double y = 0;
        std::uint64_t n = 0;
        auto next = start;
        while (!stop_requested) {
            const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() +
                             options.offset;
            const bool seen = options.gone == 0 || std::fmod(t, cycle) < options.seen;
            if (seen) {
                // The target wanders slowly; the detector adds a little noise.
                x = 0.5 * std::sin(t * 0.7) + jitter(random);
                y = 0.3 * std::cos(t * 0.4) + jitter(random);
                port.write(plexus::Value{{"kind", options.kind},
                                         {"x", std::round(x * 1000) / 1000},
                                         {"y", std::round(y * 1000) / 1000},
                                         {"certainty", std::round(certainty(random) * 100) / 100},
                                         {"n", ++n}});
            }
            next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
            std::this_thread::sleep_until(next);
        }
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-detector: " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
    return 0;
}
