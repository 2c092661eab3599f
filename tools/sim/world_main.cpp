// plexus-sim-world: the simulated world of the fetch-and-carry robot (tools/sim/README.md).
//
//     plexus-sim-world --speed 10 --seed 3
#include <CLI/CLI.hpp>

#include "world_program.hpp"

int main(int argc, char** argv) {
    plexus::sim::WorldOptions options;
    CLI::App app{
        "plexus-sim-world: a 2D world with a table, an object, a walking person and a robot's head, arm "
        "and hand; reads gaze/arm/hand commands and publishes what the robot senses (tools/sim/README.md)."};
    app.add_option("--speed", options.speed, "sim seconds per real second")
        ->check(CLI::Range(0.01, 1000.0))
        ->capture_default_str();
    app.add_option("--seed", options.seed, "seed of every random choice")->capture_default_str();
    app.add_option("--rate", options.rate, "ticks and sensor messages per sim second")
        ->check(CLI::Range(1.0, 10000.0))
        ->capture_default_str();
    app.add_option("--duration", options.duration, "sim seconds to run (0: until stopped)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    app.add_option("--prefix", options.prefix, "prefix of every port name")->capture_default_str();
    app.add_flag("--log-state", options.log_state, "print the world's state every sim second");
    CLI11_PARSE(app, argc, argv);
    return plexus::sim::run_world(options);
}
