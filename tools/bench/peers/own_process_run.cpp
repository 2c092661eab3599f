#include "own_process_run.hpp"

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "../run_deadline.hpp"

namespace plexus::bench::peers {

namespace {

// Longer than the run deadline the bench arms around every run: that one ends a wedged run.
constexpr std::chrono::seconds run_wait{run_deadline_s + 30};

PeerResult from_json(const nlohmann::json& figures) {
    PeerResult r;
    r.p50_us = figures.at("p50_us").get<double>();
    r.p99_us = figures.at("p99_us").get<double>();
    r.p999_us = figures.at("p999_us").get<double>();
    r.msgs_per_s = figures.at("msgs_per_s").get<double>();
    r.mb_per_s = figures.at("mb_per_s").get<double>();
    r.lost = figures.at("lost").get<double>();
    r.cpu_us_per_msg = figures.at("cpu_us_per_msg").get<double>();
    r.rss_mb = figures.at("rss_mb").get<double>();
    r.warning = figures.value("warning", "");
    return r;
}

/// The last line of `output` that is a JSON object with figures: the libraries of the run process
/// may print their own lines before and after it.
std::optional<nlohmann::json> figures_in(const std::string& output) {
    std::optional<nlohmann::json> found;
    std::istringstream lines(output);
    for (std::string line; std::getline(lines, line);) {
        if (line.empty() || line.front() != '{')
            continue;
        auto parsed = nlohmann::json::parse(line, nullptr, false);
        if (parsed.is_object() && parsed.contains("p50_us"))
            found = std::move(parsed);
    }
    return found;
}

}  // namespace

nlohmann::json to_json(const PeerResult& r) {
    nlohmann::json figures{{"p50_us", r.p50_us},
                           {"p99_us", r.p99_us},
                           {"p999_us", r.p999_us},
                           {"msgs_per_s", r.msgs_per_s},
                           {"mb_per_s", r.mb_per_s},
                           {"lost", r.lost},
                           {"cpu_us_per_msg", r.cpu_us_per_msg},
                           {"rss_mb", r.rss_mb}};
    if (!r.warning.empty())
        figures["warning"] = r.warning;
    return figures;
}

PeerResult run_in_own_process(const System& system, Scenario scenario, const Workload& workload,
                              const BrokerSetup& setup) {
    if (setup.self.empty())
        throw std::runtime_error(system.name + ": the bench's own path is needed to start a run process");
    const std::string log = setup.dir.file("peer-run.log");
    ChildProcess run({setup.self, "peer-run", "--system", system.name, "--scenario", name_of(scenario),
                      "--size", std::to_string(workload.size), "--count", std::to_string(workload.count),
                      "--plexusd", setup.plexusd},
                     log);
    if (!poll_until([&] { return !run.running(); }, run_wait))
        throw std::runtime_error("the run process did not finish:\n" + run.log_tail());
    const auto figures = figures_in(read_file(log));
    if (!figures)
        throw std::runtime_error("the run process printed no figures:\n" + run.log_tail());
    return from_json(*figures);
}

int run_peer_run(const PeerRunOptions& options) {
    try {
        const auto systems = all_systems();
        const auto system = std::find_if(systems.begin(), systems.end(),
                                         [&](const System& s) { return s.name == options.system; });
        if (system == systems.end())
            throw std::invalid_argument("unknown or not built system '" + options.system + "'");
        const auto scenario = std::find_if(known_scenarios().begin(), known_scenarios().end(),
                                           [&](Scenario s) { return name_of(s) == options.scenario; });
        if (scenario == known_scenarios().end())
            throw std::invalid_argument("unknown scenario '" + options.scenario + "'");
        const RunDeadline deadline;
        const TempDir dir;
        PeerResult result;
        {
            const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
            auto broker = system->start(BrokerSetup{dir, options.plexusd, self, options.size});
            result = run_scenario(*scenario, *broker, {options.size, options.count});
        }  // the system stops before its figures count as done: an error stopping it fails the run
        std::cout << to_json(result).dump() << std::endl;
        return 0;
    } catch (const std::exception& e) {
        std::cerr << "plexus-bench peer-run: " << options.system << ", " << options.scenario << ", "
                  << options.size << " B: " << e.what() << '\n';
        return 1;
    }
}

}  // namespace plexus::bench::peers
