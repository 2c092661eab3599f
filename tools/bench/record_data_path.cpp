// plexus-bench record, part 2: the data path without a recording, with a recording of the ports
// being read, and without one again (issue 28's "≤ 10% slower while recording, 0% when no one
// records").
//
// One daemon carries all three scenarios (ping-pong 64 B, stream 64 B, stream 64 KiB), each with its
// own ports. A round is, per scenario: a run with no recording ("none"), a run while the daemon
// records the scenario's reading ports ("recording"), and a run after that recording was stopped
// ("none_after"). Rounds repeat --repeat times; medians per variant. The latency scenario records
// both of its reading ports (/bench/lat-pong-in and /bench/lat-ping-in), so that every message of a
// round trip passes a tap; the streams record their sink. Each recording is stopped (its file
// written, synced and closed) before the next run starts, and its file is removed.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus_measurements.hpp"
#include "record_scenario.hpp"
#include "report.hpp"
#include "run_deadline.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

struct Scenario {
    std::string name;  ///< the JSON `scenario`
    std::string title;
    Options options;
    std::vector<std::string> recorded_ports;
    std::unique_ptr<Measurement> measurement;
    std::unique_ptr<Measurement> before_tap;  ///< on the --baseline-plexusd daemon, if given
    std::vector<RunResult> none, recording, none_after, baseline;
    std::uint64_t lost = 0;  ///< by the recorder, over all recording runs
    std::uint64_t kept = 0;
};

// A default 64 B stream of 200,000 messages lasts ~35 ms here, less than the recorder's wake-ups
// and the VM's jitter resolve (docs/BENCHMARKS.md, "Web endpoint"): the 64 B stream is longer.
constexpr std::size_t small_stream_count = 1000000;

Options tagged(const Options& given, const std::string& tag, std::size_t size, std::size_t count) {
    Options options = given;
    options.size = size;
    options.port_tag = tag;
    options.count = count;  // 0: the scenario's own default (docs/BENCHMARKS.md)
    return options;
}

/// Columns: none, recording, none_after (and before_tap); ratios to none (and none to before_tap).
void print_table(const Scenario& scenario, const std::vector<RunResult>& medians,
                 const std::string& latency_label) {
    const bool with_baseline = medians.size() == 4;
    std::printf("%s\n", scenario.title.c_str());
    std::printf("  %-26s %12s %12s %12s %s%11s %11s%s\n", "", "none", "recording", "none_after",
                with_baseline ? "  before_tap " : "", "rec/none", "after/none",
                with_baseline ? "  none/before" : "");
    auto row = [&](const char* label, double RunResult::*field) {
        const double none = medians[0].*field;
        const double recording = medians[1].*field;
        const double after = medians[2].*field;
        std::printf("  %-26s %12.2f %12.2f %12.2f", label, none, recording, after);
        if (with_baseline)
            std::printf(" %12.2f", medians[3].*field);
        std::printf(" %11.3f %11.3f", none > 0 ? recording / none : 0, none > 0 ? after / none : 0);
        if (with_baseline)
            std::printf(" %12.3f", medians[3].*field > 0 ? none / (medians[3].*field) : 0);
        std::printf("\n");
    };
    row(("p50 " + latency_label + " (us)").c_str(), &RunResult::p50_us);
    row(("p99 " + latency_label + " (us)").c_str(), &RunResult::p99_us);
    row("messages/s", &RunResult::msgs_per_s);
    row("plexusd CPU us/message", &RunResult::cpu_us_per_msg);
    auto runs = [](const std::vector<RunResult>& results, bool latency) {
        std::string text;
        for (const auto& run : results) {
            char number[32];
            std::snprintf(number, sizeof number, " %.0f", latency ? run.p50_us * 100 : run.msgs_per_s / 1e3);
            text += number;
        }
        return text;
    };
    const bool latency = latency_label == "RTT/2";
    std::printf("  each round's %s: none%s | recording%s | none_after%s",
                latency ? "p50 (10 ns)" : "messages/s (thousands)", runs(scenario.none, latency).c_str(),
                runs(scenario.recording, latency).c_str(), runs(scenario.none_after, latency).c_str());
    if (with_baseline)
        std::printf(" | before_tap%s", runs(scenario.baseline, latency).c_str());
    std::printf("\n  recorder: %llu messages kept, %llu lost over the recording runs\n\n",
                static_cast<unsigned long long>(scenario.kept),
                static_cast<unsigned long long>(scenario.lost));
}

}  // namespace

void measure_record_data_path(const Options& given) {
    OutputDir dir(given.record_dir);
    TempDir scratch;
    const auto topology = Topology::plexus(scratch, given.plexusd, 1);
    // The daemon of the commit before the tap, if given: the "0% when no one records" comparison.
    TempDir baseline_scratch;
    const auto baseline = given.baseline_plexusd.empty()
                              ? nullptr
                              : Topology::plexus(baseline_scratch, given.baseline_plexusd, 1);
    Client control = connect_client(topology->near_socket());

    std::vector<Scenario> scenarios;
    {
        Scenario latency;
        latency.name = "record_latency_1hop";
        latency.options = tagged(given, "lat", 64, given.count);
        latency.title = "latency, 1 hop, 64 B: " + std::to_string(latency_count(latency.options)) +
                        " round trips per run";
        latency.recorded_ports = {"/bench/lat-pong-in", "/bench/lat-ping-in"};
        scenarios.push_back(std::move(latency));
        for (const std::size_t size : {std::size_t{64}, std::size_t{64} << 10}) {
            Scenario stream;
            const std::string tag = size == 64 ? "small" : "large";
            stream.name = "record_throughput_1hop";
            stream.options =
                tagged(given, tag, size,
                       size == 64 ? (given.stream_count ? given.stream_count : small_stream_count) : 0);
            stream.title = "throughput, 1 hop, " + std::to_string(size) +
                           " B: " + std::to_string(throughput_count(stream.options)) + " messages per run";
            stream.recorded_ports = {"/bench/" + tag + "-sink"};
            scenarios.push_back(std::move(stream));
        }
    }
    {
        RunDeadline setup;
        for (auto& scenario : scenarios) {
            scenario.measurement = scenario.name == "record_latency_1hop"
                                       ? plexus_latency(*topology, scenario.options)
                                       : plexus_throughput(*topology, scenario.options);
            if (baseline) {
                scenario.before_tap = scenario.name == "record_latency_1hop"
                                          ? plexus_latency(*baseline, scenario.options)
                                          : plexus_throughput(*baseline, scenario.options);
            }
        }
    }
    for (int round = 0; round < given.repeat; ++round) {
        for (auto& scenario : scenarios) {
            RunDeadline per_run;
            // The baseline goes first in even rounds and last in odd ones: the order hits both alike.
            if (scenario.before_tap && round % 2 == 0)
                scenario.baseline.push_back(scenario.before_tap->run());
            scenario.none.push_back(scenario.measurement->run());
            {
                Recording recording(control, scenario.recorded_ports, dir.next("data-path", ".mcap"));
                scenario.recording.push_back(scenario.measurement->run());
                const Value status = recording.stop();
                std::filesystem::remove(recording.path());
                scenario.lost +=
                    status_count(status, "lost_messages") + status_count(status, "not_recordable");
                scenario.kept += status_count(status, "messages");
            }
            scenario.none_after.push_back(scenario.measurement->run());
            if (scenario.before_tap && round % 2 == 1)
                scenario.baseline.push_back(scenario.before_tap->run());
        }
    }

    const std::string runs =
        ", median of " + std::to_string(given.repeat) + " rounds (none, recording, none_after in turn)";
    for (auto& scenario : scenarios) {
        const RunResult none = median_of(scenario.none);
        const RunResult recording = median_of(scenario.recording);
        const RunResult after = median_of(scenario.none_after);
        const bool latency = scenario.name == "record_latency_1hop";
        if (given.json) {
            auto line = [&](const char* system, const RunResult& run) {
                std::cout << nlohmann::ordered_json{{"system", system},
                                                    {"scenario", scenario.name},
                                                    {"size", scenario.options.size},
                                                    {"p50_us", run.p50_us},
                                                    {"p99_us", run.p99_us},
                                                    {"msgs_per_s", run.msgs_per_s},
                                                    {"mb_per_s", run.mb_per_s},
                                                    {"cpu_us_per_msg", run.cpu_us_per_msg}}
                                 .dump()
                          << '\n';
            };
            line("none", none);
            line("recording", recording);
            line("none_after", after);
            if (!scenario.baseline.empty()) {
                const RunResult before = median_of(scenario.baseline);
                line("before_tap", before);
                std::cout
                    << nlohmann::ordered_json{{"scenario", scenario.name + "_no_recording_vs_before_tap"},
                                              {"size", scenario.options.size},
                                              {"p50_none_over_before", ratio(none.p50_us, before.p50_us)},
                                              {"msgs_none_over_before",
                                               ratio(none.msgs_per_s, before.msgs_per_s)},
                                              {"baseline_plexusd", given.baseline_plexusd}}
                           .dump()
                    << '\n';
            }
            std::cout
                << nlohmann::ordered_json{{"scenario", scenario.name + "_ratios"},
                                          {"size", scenario.options.size},
                                          {"p50_recording_over_none", ratio(recording.p50_us, none.p50_us)},
                                          {"p99_recording_over_none", ratio(recording.p99_us, none.p99_us)},
                                          {"msgs_recording_over_none",
                                           ratio(recording.msgs_per_s, none.msgs_per_s)},
                                          {"p50_after_over_none", ratio(after.p50_us, none.p50_us)},
                                          {"msgs_after_over_none", ratio(after.msgs_per_s, none.msgs_per_s)},
                                          {"recorder_kept", scenario.kept},
                                          {"recorder_lost", scenario.lost}}
                       .dump()
                << '\n';
        } else {
            scenario.title += runs;
            std::vector<RunResult> medians{none, recording, after};
            if (!scenario.baseline.empty())
                medians.push_back(median_of(scenario.baseline));
            print_table(scenario, medians, latency ? "RTT/2" : "write->read");
        }
    }
    std::fflush(stdout);
}

}  // namespace plexus::bench
