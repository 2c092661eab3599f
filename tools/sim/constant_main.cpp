// plexus-sim-constant: publishes one fixed JSON value at a rate: the arm's home position, the
// "open" and "close" commands, anything a connection's arbitration should fall back to.
//
//     plexus-sim-constant --out /home/out --value '{"x":0.15,"y":0}' --rate 20
#include <chrono>
#include <iostream>
#include <thread>

#include <CLI/CLI.hpp>

#include "plexus/client.hpp"
#include "stop_signal.hpp"

int main(int argc, char** argv) {
    std::string out;
    std::string text;
    double rate = 20;
    CLI::App app{"plexus-sim-constant: publishes a fixed JSON value at a rate."};
    app.add_option("--out", out, "output port")->required();
    app.add_option("--value", text, "the JSON value to publish")->required();
    app.add_option("--rate", rate, "messages per real second")
        ->check(CLI::Range(0.1, 10000.0))
        ->capture_default_str();
    CLI11_PARSE(app, argc, argv);

    const plexus::Value value = plexus::Value::parse(text, nullptr, false);
    if (value.is_discarded()) {
        std::cerr << "plexus-sim-constant: --value is not JSON: " << text << '\n';
        return static_cast<int>(plexus::ErrorCode::usage);
    }
    plexus::sim::install_stop_handlers();
    try {
        plexus::Client client;
        plexus::Port port = client.open(out);
        using Clock = std::chrono::steady_clock;
        const auto period =
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
        auto next = Clock::now();
        while (!plexus::sim::stop_requested()) {
            port.write(value);
            next += period;
            const auto now = Clock::now();
            if (next < now)
                next = now;  // behind: skip, do not burst
            // Sleep in slices of at most 100 ms so that a low rate still stops promptly.
            while (!plexus::sim::stop_requested() && Clock::now() < next)
                std::this_thread::sleep_until(std::min(next, Clock::now() + std::chrono::milliseconds(100)));
        }
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-sim-constant: " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
    return 0;
}
