#include "report.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

namespace plexus::bench {

double rounded(double value) {
    return std::round(value * 1000) / 1000;
}

double ratio(double a, double b) {
    return b > 0 ? a / b : 0;
}

std::string size_text(std::size_t size) {
    if (size >= (1u << 20))
        return std::to_string(size >> 20) + " MiB";
    if (size >= (1u << 10))
        return std::to_string(size >> 10) + " KiB";
    return std::to_string(size) + " B";
}

namespace {

nlohmann::ordered_json as_json(const std::string& system, const std::string& scenario, std::size_t size,
                               const RunResult& run) {
    return {{"system", system},
            {"scenario", scenario},
            {"size", size},
            {"p50_us", rounded(run.p50_us)},
            {"p99_us", rounded(run.p99_us)},
            {"mean_us", rounded(run.mean_us)},
            {"msgs_per_s", rounded(run.msgs_per_s)},
            {"mb_per_s", rounded(run.mb_per_s)},
            {"cpu_us_per_msg", rounded(run.cpu_us_per_msg)}};
}

void row(const char* label, double plexus, double floor) {
    const double ratio = floor > 0 ? plexus / floor : 0;
    std::printf("  %-28s %14.2f %14.2f %14.2f\n", label, plexus, floor, ratio);
}

}  // namespace

void print(const ScenarioResult& result, bool json) {
    if (json) {
        std::cout << as_json(result.plexus_label, result.scenario, result.size, result.plexus).dump() << '\n'
                  << as_json(result.floor_label, result.scenario, result.size, result.floor).dump() << '\n';
        return;
    }
    std::printf("%s\n", result.title.c_str());
    std::printf("  %-28s %14s %14s %14s\n", "", result.plexus_label.c_str(), result.floor_label.c_str(),
                (result.plexus_label + "/" + result.floor_label).c_str());
    row(("p50 " + result.latency_label + " (us)").c_str(), result.plexus.p50_us, result.floor.p50_us);
    row(("p99 " + result.latency_label + " (us)").c_str(), result.plexus.p99_us, result.floor.p99_us);
    if (result.show_mean)
        row(("mean " + result.latency_label + " (us)").c_str(), result.plexus.mean_us, result.floor.mean_us);
    row(result.messages_label.c_str(), result.plexus.msgs_per_s, result.floor.msgs_per_s);
    row("MB/s (payload, 10^6 B)", result.plexus.mb_per_s, result.floor.mb_per_s);
    row("broker CPU us/message", result.plexus.cpu_us_per_msg, result.floor.cpu_us_per_msg);
    std::printf("  plexusd peak RSS (MiB):");
    for (const double mb : result.plexusd_peak_rss_mb)
        std::printf(" %.1f", mb);
    std::printf("\n\n");
    std::fflush(stdout);
}

void print(const VariantsResult& result, bool json) {
    auto switch_ms = [&](std::size_t i) { return i < result.switch_ms.size() ? result.switch_ms[i] : -1.0; };
    if (json) {
        for (std::size_t i = 0; i < result.systems.size(); ++i) {
            const auto& [system, run] = result.systems[i];
            auto line = as_json(system, result.scenario, result.size, run);
            if (switch_ms(i) >= 0)
                line["switch_ms"] = rounded(switch_ms(i));
            std::cout << line.dump() << '\n';
        }
        return;
    }
    std::printf("%s\n", result.title.c_str());
    std::printf("  %-18s %12s %12s %12s %14s %16s%s\n", "system", "msgs/s", "vs first", "cpu us/msg",
                "added us/msg", "p50 write->read", result.switch_ms.empty() ? "" : "   switch ms");
    const RunResult& base = result.systems.front().second;
    for (std::size_t i = 0; i < result.systems.size(); ++i) {
        const auto& [system, run] = result.systems[i];
        std::printf("  %-18s %12.0f %11.1f%% %12.3f %14.3f %14.1f us", system.c_str(), run.msgs_per_s,
                    base.msgs_per_s > 0 ? 100 * run.msgs_per_s / base.msgs_per_s : 0, run.cpu_us_per_msg,
                    run.cpu_us_per_msg - base.cpu_us_per_msg, run.p50_us);
        if (switch_ms(i) >= 0)
            std::printf(" %12.3f", switch_ms(i));
        std::printf("\n");
    }
}

void print(const MemoryResult& result, bool json) {
    const std::string ports_scenario = "memory_" + std::to_string(result.ports) + "_ports";
    if (json) {
        std::cout << nlohmann::ordered_json{{"system", "plexus"},
                                            {"scenario", "memory_idle"},
                                            {"rss_mb", rounded(result.idle_mb)}}
                         .dump()
                  << '\n'
                  << nlohmann::ordered_json{{"system", "plexus"},
                                            {"scenario", ports_scenario},
                                            {"rss_mb", rounded(result.ports_mb)}}
                         .dump()
                  << '\n';
        return;
    }
    std::printf("plexusd resident memory (VmRSS, MiB)\n");
    std::printf("  %-28s %14.2f\n", "idle", result.idle_mb);
    std::printf("  %-28s %14.2f\n", (std::to_string(result.ports) + " ports open").c_str(), result.ports_mb);
    std::fflush(stdout);
}

}  // namespace plexus::bench
