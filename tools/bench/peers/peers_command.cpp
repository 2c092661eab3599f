#include "peers_command.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "../measurement.hpp"
#include "../run_deadline.hpp"
#include "own_process_run.hpp"
#include "peer_scenarios.hpp"
#include "pubsub.hpp"

namespace plexus::bench::peers {

namespace {

std::vector<System> chosen_systems(const std::vector<std::string>& names) {
    auto systems = all_systems();
    if (names.empty())
        return systems;
    std::vector<System> chosen;
    for (const auto& name : names) {
        auto found =
            std::find_if(systems.begin(), systems.end(), [&](const System& s) { return s.name == name; });
        if (found == systems.end()) {
            std::string known;
            for (const auto& system : systems)
                known += (known.empty() ? "" : ", ") + system.name;
            throw std::invalid_argument(
                "unknown or not built system '" + name + "' (built: " + known +
                (peers_built() ? ")" : "; the peers need scripts/bench-peers-setup)"));
        }
        chosen.push_back(*found);
    }
    return chosen;
}

std::vector<Scenario> chosen_scenarios(const std::vector<std::string>& names) {
    if (names.empty())
        return all_scenarios();
    std::vector<Scenario> chosen;
    for (const auto& name : names) {
        auto found = std::find_if(known_scenarios().begin(), known_scenarios().end(),
                                  [&](Scenario s) { return name_of(s) == name; });
        if (found == known_scenarios().end())
            throw std::invalid_argument("unknown scenario '" + name +
                                        "' (pingpong, rate_1khz, throughput, fanout_8, requestreply)");
        chosen.push_back(*found);
    }
    return chosen;
}

PeerResult median_of(const std::vector<PeerResult>& runs) {
    auto figure = [&](double PeerResult::*member) {
        std::vector<double> values;
        for (const auto& run : runs)
            values.push_back(run.*member);
        return median(std::move(values));
    };
    PeerResult result;
    for (auto member :
         {&PeerResult::p50_us, &PeerResult::p99_us, &PeerResult::p999_us, &PeerResult::msgs_per_s,
          &PeerResult::mb_per_s, &PeerResult::lost, &PeerResult::cpu_us_per_msg, &PeerResult::rss_mb})
        result.*member = figure(member);
    for (const auto& run : runs) {
        if (!run.warning.empty())
            result.warning = run.warning;
    }
    return result;
}

std::string self_path() {
    return std::filesystem::read_symlink("/proc/self/exe").string();
}

std::string size_label(std::size_t size) {
    if (size >= (1u << 20) && size % (1u << 20) == 0)
        return std::to_string(size >> 20) + " MiB";
    if (size >= 1024 && size % 1024 == 0)
        return std::to_string(size >> 10) + " KiB";
    return std::to_string(size) + " B";
}

std::string what_is_measured(Scenario scenario) {
    switch (scenario) {
        case Scenario::pingpong:
            return "latency = round trip / 2";
        case Scenario::rate_1khz:
            return "one-way latency at 1 kHz";
        case Scenario::throughput:
            return "one subscriber, as fast as possible; latency = send to receive under load";
        case Scenario::fanout_8:
            return "8 subscribers; msgs/s = deliveries to all; latency of the subscriber that finished last";
        case Scenario::requestreply:
            return "a request and its answer, one at a time; latency = the whole round trip (not halved)";
    }
    return "";
}

/// The medians of one row's systems, in the order they were measured; Plexus first.
struct Row {
    Scenario scenario;
    std::size_t size;
    std::size_t count;
    std::vector<std::pair<std::string, PeerResult>> results;
    std::vector<std::pair<std::string, std::string>> failures;
};

void print_json(const Row& row) {
    for (const auto& [system, r] : row.results) {
        nlohmann::json line = to_json(r);
        line["system"] = system;
        line["scenario"] = name_of(row.scenario);
        line["size"] = row.size;
        std::cout << line.dump() << '\n';
    }
    std::cout.flush();
}

void print_table(const Row& row, int repeat) {
    std::printf("\n%s, %s: %s (%zu per run, median of %d)\n", name_of(row.scenario).c_str(),
                size_label(row.size).c_str(), what_is_measured(row.scenario).c_str(), row.count, repeat);
    std::printf("  %-13s %9s %9s %9s %12s %9s %8s %10s %8s %10s %10s\n", "system", "p50 us", "p99 us",
                "p99.9 us", "msgs/s", "MB/s", "lost", "cpu us/msg", "rss MB", "p50/plx", "msgs/plx");
    const PeerResult* plexus = nullptr;
    for (const auto& [system, result] : row.results) {
        if (system == "plexus")
            plexus = &result;
    }
    for (const auto& [system, r] : row.results) {
        const double p50_ratio = plexus && plexus->p50_us > 0 ? r.p50_us / plexus->p50_us : 0;
        const double rate_ratio = plexus && plexus->msgs_per_s > 0 ? r.msgs_per_s / plexus->msgs_per_s : 0;
        std::printf("  %-13s %9.1f %9.1f %9.1f %12.0f %9.1f %8.0f %10.2f %8.1f %9.2fx %9.2fx\n",
                    system.c_str(), r.p50_us, r.p99_us, r.p999_us, r.msgs_per_s, r.mb_per_s, r.lost,
                    r.cpu_us_per_msg, r.rss_mb, p50_ratio, rate_ratio);
        if (!r.warning.empty())
            std::printf("  %-13s note: %s\n", "", r.warning.c_str());
    }
    for (const auto& [system, why] : row.failures)
        std::printf("  %-13s FAILED: %s\n", system.c_str(), why.c_str());
    std::fflush(stdout);
}

}  // namespace

int run_peers(const PeersOptions& options) {
    const auto systems = chosen_systems(options.systems);
    const auto scenarios = chosen_scenarios(options.scenarios);
    const int repeat = options.quick ? 1 : options.repeat;
    if (!peers_built() && !options.json) {
        std::printf(
            "Only Plexus is built into this bench: run scripts/bench-peers-setup to add Mosquitto, NATS, "
            "ZeroMQ, Redis, Cyclone DDS and iceoryx.\n");
    }
    const std::string self = self_path();
    int status = 0;
    for (const Scenario scenario : scenarios) {
        for (const std::size_t size : options.sizes) {
            Row row{scenario,
                    size,
                    options.count > 0 ? options.count : default_count(scenario, size, options.quick),
                    {},
                    {}};
            std::map<std::string, std::vector<PeerResult>> runs;
            std::map<std::string, std::string> failed;
            // Systems alternate run by run, so that drift of this machine hits all of them alike.
            for (int run = 0; run < repeat; ++run) {
                for (const auto& system : systems) {
                    if (failed.count(system.name))
                        continue;
                    try {
                        const RunDeadline deadline;
                        const TempDir dir;
                        const BrokerSetup setup{dir, options.plexusd, self, size};
                        const Workload workload{size, row.count};
                        if (system.own_process) {
                            runs[system.name].push_back(
                                run_in_own_process(system, scenario, workload, setup));
                        } else {
                            auto broker = system.start(setup);
                            runs[system.name].push_back(run_scenario(scenario, *broker, workload));
                        }
                    } catch (const std::exception& e) {
                        failed[system.name] = e.what();
                        std::cerr << "plexus-bench peers: " << system.name << ", " << name_of(scenario)
                                  << ", " << size << " B: " << e.what() << '\n';
                        status = 1;
                    }
                }
            }
            for (const auto& system : systems) {
                if (failed.count(system.name))
                    row.failures.emplace_back(system.name, failed[system.name]);
                else if (!runs[system.name].empty())
                    row.results.emplace_back(system.name, median_of(runs[system.name]));
            }
            if (options.json)
                print_json(row);
            else
                print_table(row, repeat);
        }
    }
    return status;
}

}  // namespace plexus::bench::peers
