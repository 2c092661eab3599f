// plexus-bench monitor: what a port monitor costs. One daemon, three streams of maps through it,
// alternated run by run: no monitor, a recv-side accept that reads one field, and a recv-side
// update that rewrites the payload. The figures that matter are the differences to `none`.
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "plexus_measurements.hpp"
#include "process_stats.hpp"
#include "report.hpp"
#include "run_deadline.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

constexpr const char* accept_script = R"(-- reads one field of each message
PortMonitor.accept = function(msg) return msg.data.c > 0.5 end
)";

constexpr const char* empty_script = R"(-- the least a monitor can do: called, touches nothing
PortMonitor.accept = function(msg) return true end
)";

constexpr const char* latency_script = R"(-- reads the payload of each message (a blob)
PortMonitor.accept = function(msg) return #msg.data > 0 end
)";
constexpr const char* update_script = R"(-- rewrites the payload: one field changed, one added
PortMonitor.update = function(msg)
    local d = msg.data
    d.c = d.c / 2
    d.seen = msg.seq
    return msg
end
)";

}  // namespace

int run_monitor(const Options& options) {
    TempDir dir;
    std::ofstream(dir.file("accept_one_field.lua")) << accept_script;
    std::ofstream(dir.file("update_rewrite.lua")) << update_script;
    std::ofstream(dir.file("accept_empty.lua")) << empty_script;
    const auto topology = Topology::plexus(dir, options.plexusd, 1, {"--scripts", dir.path()});

    std::vector<std::pair<std::string, std::string>> variants{
        {"none", "local"},
        {"accept_one_field", "local+recv.portmonitor+type.lua+file.accept_one_field"},
        {"update_rewrite", "local+recv.portmonitor+type.lua+file.update_rewrite"},
    };
    if (options.empty_accept)
        variants.emplace_back("accept_empty", "local+recv.portmonitor+type.lua+file.accept_empty");
    std::vector<std::unique_ptr<Measurement>> measurements;
    for (const auto& [name, carrier] : variants) {
        measurements.push_back(
            plexus_stream(*topology, options,
                          StreamSpec{name + "-", detection(options.size), carrier, check_detection, {}}));
    }
    std::vector<std::vector<RunResult>> runs(variants.size());
    {
        RunDeadline deadline;
        for (int run = 0; run < options.repeat; ++run) {
            for (std::size_t i = 0; i < variants.size(); ++i) {
                RunDeadline per_run;
                runs[i].push_back(measurements[i]->run());
            }
        }
    }
    VariantsResult result;
    result.scenario = "monitor_1hop";
    result.size = options.size;
    result.title = "port monitors, 1 hop, " + std::to_string(options.size) +
                   " B maps: " + std::to_string(throughput_count(options)) + " messages per run, median of " +
                   std::to_string(options.repeat) + " runs";
    for (std::size_t i = 0; i < variants.size(); ++i)
        result.systems.emplace_back(variants[i].first, median_of(runs[i]));
    print(result, options.json);
    return 0;
}

int run_monitor_latency(const Options& options) {
    // The same script inline on the daemon's thread (the default for a cheap monitor) and, in a
    // second daemon started with --no-inline-monitors, on a worker: the hop's cost is the difference.
    TempDir dir;
    std::ofstream(dir.file("latency_accept.lua")) << latency_script;
    const auto topology = Topology::plexus(dir, options.plexusd, 1, {"--scripts", dir.path()});
    TempDir workers_dir;
    const auto workers_only =
        Topology::plexus(workers_dir, options.plexusd, 1, {"--scripts", dir.path(), "--no-inline-monitors"});
    struct Variant {
        std::string name;
        std::string carrier;
        const Topology* topology;
    };
    const Variant variants[] = {
        {"none", "local", topology.get()},
        {"accept_inline", "local+recv.portmonitor+type.lua+file.latency_accept", topology.get()},
        {"accept_on_worker", "local+recv.portmonitor+type.lua+file.latency_accept", workers_only.get()},
    };
    std::vector<std::unique_ptr<Measurement>> measurements;
    for (const auto& variant_spec : variants) {
        Options variant = options;
        variant.carrier = variant_spec.carrier;
        variant.port_tag = variant_spec.name;
        measurements.push_back(plexus_latency(*variant_spec.topology, variant));
    }
    std::vector<std::vector<RunResult>> runs(std::size(variants));
    {
        RunDeadline deadline;
        for (int run = 0; run < options.repeat; ++run) {
            for (std::size_t i = 0; i < std::size(variants); ++i) {
                RunDeadline per_run;
                runs[i].push_back(measurements[i]->run());
            }
        }
    }
    VariantsResult result;
    result.scenario = "monitor_latency_1hop";
    result.size = options.size;
    result.title = "one-hop latency with and without a recv monitor (inline, or on a worker), " +
                   std::to_string(options.size) + " B: " + std::to_string(latency_count(options)) +
                   " round trips per run, median of " + std::to_string(options.repeat) + " runs";
    for (std::size_t i = 0; i < std::size(variants); ++i)
        result.systems.emplace_back(variants[i].name, median_of(runs[i]));
    print(result, options.json);
    return 0;
}

}  // namespace plexus::bench
