#pragma once
// `plexus-bench peers`: Plexus and the brokers users would pick instead, same jobs, same run.

#include <cstddef>
#include <string>
#include <vector>

namespace plexus::bench::peers {

struct PeersOptions {
    bool quick = false;  ///< a tenth of the messages and one run: to see that everything works
    bool json = false;   ///< one JSON object per row
    int repeat = 5;      ///< runs per system and row (alternating systems); medians are reported
    std::vector<std::size_t> sizes{64, 4096, 1u << 20};
    std::vector<std::string> systems;    ///< empty: every system built in
    std::vector<std::string> scenarios;  ///< empty: all
    std::size_t count = 0;               ///< messages or round trips per run; 0: by scenario and size
    std::string plexusd;
};

/// Runs every chosen scenario and size on every chosen system; returns the exit status
/// (0, or 1 if some system failed a row; the other rows are still printed).
int run_peers(const PeersOptions& options);

}  // namespace plexus::bench::peers
