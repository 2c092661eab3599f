#pragma once
// Printing results: a small table for people, or one JSON object per line for programs.

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "measurement.hpp"

namespace plexus::bench {

/// Three decimals are more than the measurements are worth; they keep the JSON short.
double rounded(double value);
/// a / b, or 0 when there is no b to compare with.
double ratio(double a, double b);
/// "64 B", "4 KiB", "1 MiB".
std::string size_text(std::size_t size);

/// One scenario measured on both systems (medians over the runs).
struct ScenarioResult {
    std::string scenario;       ///< e.g. "latency_1hop"; the JSON `scenario`
    std::string title;          ///< a line saying what was run, for the table
    std::string latency_label;  ///< what p50/p99 measure in this scenario
    std::size_t size = 0;
    RunResult plexus;
    RunResult floor;
    /// The JSON `system` and column of each (at most 14 characters); the ratio is plexus / floor.
    /// Another pair compares Plexus with itself (`plexus-bench web`: "web" against "no_http").
    std::string plexus_label = "plexus";
    std::string floor_label = "floor";
    /// The table's row of RunResult::msgs_per_s ("messages/s (2 per call)" for calls).
    std::string messages_label = "messages/s";
    /// The table also shows the mean latency (the JSON always has `mean_us`).
    bool show_mean = false;
    std::vector<double> plexusd_peak_rss_mb;  ///< VmHWM of each daemon at the end (table only)
};

/// Resident memory of plexusd, idle and with ports open.
struct MemoryResult {
    double idle_mb = 0;
    double ports_mb = 0;
    std::size_t ports = 0;
};

/// Several variants of one system measured in one run (e.g. with and without a monitor); the
/// first is the baseline the others are compared with.
struct VariantsResult {
    std::string scenario;
    std::string title;
    std::size_t size = 0;
    std::vector<std::pair<std::string, RunResult>> systems;  ///< the JSON `system`, and its medians
    /// Optional, one per system: a switch time in ms (the JSON `switch_ms`); negative = none.
    std::vector<double> switch_ms;
};

void print(const ScenarioResult& result, bool json);
void print(const VariantsResult& result, bool json);
void print(const MemoryResult& result, bool json);

}  // namespace plexus::bench
