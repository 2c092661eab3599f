// plexus what-if FILE.mcap PORT [--carrier SOURCE=CARRIER]... [--json] [--svg FILE]: a recorded
// port's arbitration and monitors re-run offline (tools/record/what_if.hpp), the decisions that
// come out otherwise printed.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "plexus/mcap/reader.hpp"
#include "plexus/proto/port_name.hpp"
#include "recorded_port.hpp"
#include "timeline_svg.hpp"
#include "what_if.hpp"

namespace plexus::cli {

namespace {

std::string seconds_text(double value) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.3f", value);
    return buffer;
}

/// SOURCE=CARRIER, split at the first '=' (a carrier may hold '=' in a script option, a source never).
std::map<std::string, std::string> carriers_of(const std::vector<std::string>& given) {
    std::map<std::string, std::string> carriers;
    for (const auto& text : given) {
        const auto equals = text.find('=');
        if (equals == std::string::npos || equals == 0 || equals + 1 == text.size())
            throw Error(ErrorCode::usage, "--carrier " + text +
                                              ": expected SOURCE=CARRIER, e.g. "
                                              "--carrier /obj/out=local+recv.priority+tc.0.5+ex./face/out:0");
        const std::string source = text.substr(0, equals);
        if (auto error = proto::port_name_error(source))
            throw Error(ErrorCode::usage, "--carrier " + text + ": " + *error);
        if (!carriers.emplace(source, text.substr(equals + 1)).second)
            throw Error(ErrorCode::usage, "--carrier: two carriers for " + source);
    }
    return carriers;
}

void print_text(const record::RecordedPort& port, const record::WhatIfResult& result) {
    for (const auto& source : result.sources) {
        if (source.replaced)
            std::cout << "what-if: " << source.source << " -> " << port.port << " over " << source.carrier
                      << '\n';
    }
    for (const auto& decision : result.decisions) {
        if (decision.changed())
            std::cout << seconds_text(decision.time) << " s  " << decision.source << " seq " << decision.seq
                      << "  " << decision.recorded << " -> " << decision.what_if << '\n';
    }
    std::cout << "messages " << result.compared << ", changed " << result.changed;
    if (result.undecided + result.warm_up > 0) {
        std::cout << " (not compared: " << result.undecided << " without a recorded decision, "
                  << result.warm_up
                  << " in the warm-up while stimulation from before the recording could count)";
    }
    std::cout << '\n';
    for (const auto& source : result.sources) {
        std::cout << "  " << source.source << ": " << source.messages << " messages, " << source.changed
                  << " changed, delivered " << source.recorded_delivered << " -> " << source.what_if_delivered
                  << '\n';
    }
    std::cout << "winner changes: recorded " << result.recorded_winner_changes << ", what-if "
              << result.what_if_winner_changes << '\n';
    if (result.script_errors > 0)
        std::cout << "script errors in the re-run: " << result.script_errors << '\n';
    if (result.publishes_ignored > 0)
        std::cout << "PortMonitor.publish calls not carried out offline: " << result.publishes_ignored
                  << '\n';
    if (result.trig_ignored)
        std::cout << "a monitor asked for trig(): it is not called offline (its timer is not recorded)\n";
}

void print_json(const record::WhatIfResult& result) {
    for (const auto& decision : result.decisions) {
        if (!decision.changed())
            continue;
        nlohmann::ordered_json line{{"source", decision.source},
                                    {"seq", decision.seq},
                                    {"time", decision.time},
                                    {"recorded", decision.recorded},
                                    {"what_if", decision.what_if}};
        std::cout << line.dump() << '\n';
    }
    // Exactly this shape: tests and scripts read the last line as it is.
    std::cout << "{\"messages\": " << result.compared << ", \"changed\": " << result.changed << "}\n";
}

}  // namespace

int what_if(const WhatIfArgs& args) {
    // The daemon's libraries log to spdlog; stdout is the report's (--json is read by programs).
    auto logger = spdlog::stderr_color_mt("what-if");
    logger->set_level(spdlog::level::warn);
    spdlog::set_default_logger(logger);

    if (auto error = proto::port_name_error(args.port))
        throw Error(ErrorCode::usage, "PORT " + args.port + ": " + *error);
    record::WhatIfOptions options;
    options.carriers = carriers_of(args.carriers);
    options.script_dirs = args.script_dirs;
    options.monitor_lib_dirs = args.monitor_lib_dirs;

    auto reader = mcap::Reader::open(args.file);
    if (!reader)  // the reader's message names the file and the offset
        throw Error(ErrorCode::refused, reader.error().message);
    const auto ports = record::recorded_ports(*reader);
    if (std::find(ports.begin(), ports.end(), args.port) == ports.end()) {
        // A damaged file may have lost the port with its summary: read it through first, so that
        // the damage (and its offset) is what the user hears about.
        if (auto whole = reader->for_each_message([](const mcap::MessageView&) { return true; }); !whole)
            throw Error(ErrorCode::refused, args.file + ": " + whole.error().message);
        std::string known;
        for (const auto& name : ports)
            known += (known.empty() ? "" : ", ") + name;
        throw Error(ErrorCode::usage,
                    "port " + args.port + " is not in " + args.file +
                        (known.empty() ? " (it records no messages)" : " (it records " + known + ")"));
    }
    // Payloads are kept only for connections whose monitors will read them, recorded or what-if:
    // a port of camera images re-runs without holding every image.
    record::ReadOptions read;
    read.wants_payload = [&](const record::RecordedConnection& connection) {
        const auto replaced = options.carriers.find(connection.source);
        return record::needs_payloads(replaced != options.carriers.end() ? replaced->second
                                                                         : connection.carrier);
    };
    auto recorded = record::read_recorded_port(*reader, args.port, read);
    if (!recorded)
        throw Error(ErrorCode::refused, args.file + ": " + recorded.error().message);
    auto result = record::what_if(*recorded, options);
    if (!result)
        throw Error(ErrorCode::usage, result.error().message);

    if (args.json)
        print_json(*result);
    else
        print_text(*recorded, *result);
    if (!args.svg.empty()) {
        std::ofstream out(args.svg, std::ios::binary | std::ios::trunc);
        out << record::timeline_svg(*recorded, *result, "what-if " + args.port + " (" + args.file + ")");
        out.close();
        if (!out)
            throw Error(ErrorCode::refused, "cannot write the SVG to " + args.svg);
    }
    return 0;
}

}  // namespace plexus::cli
