// plexus-bench record, part 3: how fast `plexus what-if` re-runs a recorded port, in recorded
// messages per second of wall time (the process's start and the reading of the file included).
//
// The recording is made here, on one daemon started with --scripts configs/monitors, of two
// arbitrated ports:
//   /bench/gaze: the gaze demo of README.md's arbitration section: /bench/face always, /bench/object
//                in spells of 4,000 rounds (0.8 s, longer than tc) on and off, with recv.priority (tc 0.5 s,
//                the object inhibiting the face);
//   /bench/head: the two-trackers example: /bench/tmpl and /bench/pf through the Lua certainty
//                monitor (threshold 0.6, events e_template_ok / e_particle_ok, keep) with constraints,
//                their certainties crossing the threshold in spells.
// The writer paces itself (one round of writes every 200 us), so that stimulation decays and events
// change between messages as they would live, not only within one burst.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "hosts_network.hpp"
#include "plexus_measurements.hpp"
#include "record_scenario.hpp"
#include "run_deadline.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr auto write_period = 200us;
constexpr int object_spell = 4000;  ///< rounds (0.8 s) the object is seen, then not: longer than tc

struct PortCase {
    std::string label;  ///< the JSON `case`
    std::string port;
    std::vector<std::string> extra;  ///< further what-if arguments
    std::uint64_t input = 0;         ///< messages written into the port's connections
};

/// The last line of what-if's --json output: {"messages": N, "changed": K}.
nlohmann::json summary_line(const std::string& output) {
    std::istringstream lines(output);
    std::string line;
    nlohmann::json last;
    while (std::getline(lines, line)) {
        auto parsed = nlohmann::json::parse(line, nullptr, false);
        if (!parsed.is_discarded() && parsed.is_object() && parsed.contains("messages") &&
            parsed.contains("changed"))
            last = std::move(parsed);
    }
    return last;
}

/// Records the two ports while the writer runs `rounds` rounds; returns the file's path and fills in
/// each case's input count.
std::string make_recording(const Options& options, OutputDir& dir, std::vector<PortCase>& cases, int rounds) {
    TempDir scratch;
    const auto topology = Topology::plexus(scratch, options.plexusd, 1, {"--scripts", options.scripts_dir});
    Client writer = connect_client(topology->near_socket());
    Client reader = connect_client(topology->near_socket());
    Port face = writer.open("/bench/face");
    Port object = writer.open("/bench/object");
    Port tmpl = writer.open("/bench/tmpl");
    Port pf = writer.open("/bench/pf");
    Port gaze = reader.open("/bench/gaze");
    Port head = reader.open("/bench/head");
    connect_when_registered(writer, face.name(), gaze.name(), "local+recv.priority+tc.0.5");
    connect_when_registered(writer, object.name(), gaze.name(),
                            "local+recv.priority+tc.0.5+ex./bench/face:-1");
    const std::string monitor = "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.6+keep";
    connect_when_registered(writer, tmpl.name(), head.name(),
                            monitor + "+event.e_template_ok+constraint.e_template_ok and not e_particle_ok");
    connect_when_registered(writer, pf.name(), head.name(),
                            monitor + "+event.e_particle_ok+constraint.e_particle_ok");
    std::uint64_t gaze_input = 0, head_input = 0;
    const std::string path = dir.next("what-if", ".mcap");
    {
        // The readers only drain: what reaches them does not matter, the recorded decisions do.
        Subscription drain_gaze(gaze, [](const Received&) {});
        Subscription drain_head(head, [](const Received&) {});
        Recording recording(reader, {gaze.name(), head.name()}, path);
        auto next = Clock::now();
        for (int i = 0; i < rounds; ++i) {
            face.write(Value{{"x", i}}, true);
            ++gaze_input;
            if ((i / object_spell) % 2 == 0) {
                object.write(Value{{"x", -i}}, true);
                ++gaze_input;
            }
            tmpl.write(Value{{"certainty", (i / 300) % 3 == 0 ? 0.3 : 0.9}}, true);
            pf.write(Value{{"certainty", (i / 700) % 2 == 0 ? 0.8 : 0.2}}, true);
            head_input += 2;
            next += write_period;
            std::this_thread::sleep_until(next);  // the pace of the detectors, not a wait for a condition
        }
        // A control request on the writer's own session is answered after the data frames it sent
        // before it were handled: then every message has reached its port. The Lua monitors decide
        // on a worker, a little later; a message still undecided at the stop is not compared by
        // what-if (it says how many), so a short grace is all this needs.
        (void)writer.stats();
        std::this_thread::sleep_for(200ms);
        const Value status = recording.stop();
        check_kept(status, gaze_input + head_input, "what-if recording");
    }
    for (auto& each : cases)
        each.input = each.port == "/bench/gaze" ? gaze_input : head_input;
    return path;
}

}  // namespace

void measure_what_if(const Options& options) {
    if (run_command({options.plexus_cli, "what-if", "--help"}).status != 0) {
        if (options.json) {
            std::cout << nlohmann::ordered_json{{"scenario", "what_if"}, {"available", false}}.dump() << '\n';
        } else {
            std::printf("what-if: %s has no what-if command (not merged into this branch yet); skipped\n\n",
                        options.plexus_cli.c_str());
        }
        return;
    }
    OutputDir dir(options.record_dir);
    std::vector<PortCase> cases{
        {"gaze_recorded_carriers", "/bench/gaze", {}, 0},
        {"gaze_object_weight_0",
         "/bench/gaze",
         {"--carrier", "/bench/object=local+recv.priority+tc.0.5+ex./bench/face:0"},
         0},
        {"head_lua_recorded_carriers", "/bench/head", {"--scripts", options.scripts_dir}, 0},
    };
    std::string path;
    {
        RunDeadline recording;
        path = make_recording(options, dir, cases, options.what_if_rounds);
    }
    const auto file_bytes = file_size(path);
    if (!options.json) {
        std::printf("what-if speed: a recording of %d rounds (%s, %.1f MB), median of %d runs per case\n",
                    options.what_if_rounds, path.c_str(), static_cast<double>(file_bytes) / 1e6,
                    options.repeat);
        std::printf("  %-28s %10s %10s %10s %10s %14s\n", "case", "input", "compared", "changed", "wall s",
                    "messages/s");
    }
    for (const auto& each : cases) {
        std::vector<std::string> argv{options.plexus_cli, "what-if", path, each.port, "--json"};
        argv.insert(argv.end(), each.extra.begin(), each.extra.end());
        std::vector<double> seconds;
        nlohmann::json summary;
        std::string last_output;
        for (int run = 0; run < options.repeat; ++run) {
            RunDeadline per_run;
            const auto start = Clock::now();
            const auto result = run_command(argv);
            seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
            summary = summary_line(result.output);
            last_output = result.output;
            if (result.status != 0 || summary.is_null())
                throw std::runtime_error("plexus what-if failed (" + std::to_string(result.status) +
                                         "): " + result.output.substr(0, 2000));
        }
        // With the recorded carriers what-if must reproduce every decision (issue 28): a difference
        // is a finding, shown rather than averaged away.
        if (each.extra.empty() || each.extra.front() != "--carrier") {
            if (summary.value("changed", 0) != 0) {
                std::cerr << "plexus-bench: what-if on " << each.port
                          << " with the recorded carriers changed decisions; the last run said:\n";
                std::istringstream lines(last_output);
                std::string line;
                for (int shown = 0; std::getline(lines, line) && shown < 5; ++shown)
                    std::cerr << "  " << line << '\n';
            }
        }
        const double wall = median(seconds);
        const double rate = static_cast<double>(each.input) / wall;
        if (options.json) {
            std::cout << nlohmann::ordered_json{{"scenario", "what_if"},
                                                {"case", each.label},
                                                {"port", each.port},
                                                {"file_bytes", file_bytes},
                                                {"input_messages", each.input},
                                                {"compared", summary["messages"]},
                                                {"changed", summary["changed"]},
                                                {"wall_s", wall},
                                                {"msgs_per_s", rate}}
                             .dump()
                      << '\n';
        } else {
            std::printf("  %-28s %10llu %10llu %10llu %10.3f %14.0f\n", each.label.c_str(),
                        static_cast<unsigned long long>(each.input),
                        summary["messages"].get<unsigned long long>(),
                        summary["changed"].get<unsigned long long>(), wall, rate);
        }
    }
    if (!options.record_dir.empty())
        std::filesystem::remove(path);
    if (!options.json)
        std::printf("\n");
    std::fflush(stdout);
}

}  // namespace plexus::bench
