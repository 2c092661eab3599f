#pragma once
// plexus-sim-world's loop: steps the WorldModel at a fixed rate in sim time, paced to real time
// divided by the speed, reads the command ports each tick and publishes the sensor ports.
#include <cstdint>
#include <string>

namespace plexus::sim {

struct WorldOptions {
    double speed = 1;        ///< sim seconds per real second
    std::uint64_t seed = 1;  ///< every random choice comes from it
    double rate = 50;        ///< ticks (and sensor messages) per sim second
    double duration = 0;     ///< sim seconds; 0 = until stopped
    std::string prefix = "/world";
    bool log_state = false;  ///< a state line on stderr every sim second
};

/// Runs until the duration is over or SIGINT/SIGTERM; returns the exit status.
int run_world(const WorldOptions& options);

}  // namespace plexus::sim
