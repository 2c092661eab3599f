// plexus events PORT [--check] [--watch] [--json]: the arbitration of an input port, live.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <thread>

#include "commands.hpp"
#include "counter.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/port_name.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

std::string fixed(double value, int digits) {
    std::ostringstream out;
    out << std::fixed << std::setprecision(digits) << value;
    return out.str();
}

std::string counters_line(const Value& c) {
    std::ostringstream out;
    out << "received " << counter(c, "received") << "  accepted " << counter(c, "accepted") << "  delivered "
        << counter(c, "delivered") << "  dropped: accept " << counter(c, "dropped_by_accept")
        << ", constraint " << counter(c, "dropped_by_constraint") << ", priority "
        << counter(c, "dropped_by_priority") << ", queue " << counter(c, "dropped_by_queue")
        << "  script errors " << counter(c, "script_errors");
    return out.str();
}

void print_overlaps(const Value& answer) {
    const auto overlaps = answer.value("overlaps", Value::array());
    if (overlaps.empty()) {
        std::cout << "check: at most one connection can deliver at any time\n";
        return;
    }
    for (const auto& overlap : overlaps) {
        std::cout << "check: OVERLAP " << overlap.value("first", "") << " and " << overlap.value("second", "")
                  << " can both deliver, " << overlap.value("explanation", "") << '\n';
    }
}

void print_text(const Value& answer, bool check) {
    std::cout << answer.value("port", "") << " on node '" << answer.value("node", "") << "'\n";
    const auto& winner = answer["winner"];
    if (!winner.is_null())
        std::cout << "stimulation winner: " << winner.get<std::string>() << '\n';
    if (answer.contains("inconsistent"))
        std::cout << "INCONSISTENT: " << answer.value("inconsistent", "") << '\n';
    std::cout << "\nevents:\n";
    const auto events = answer.value("events", Value::array());
    if (events.empty())
        std::cout << "  (none)\n";
    for (const auto& event : events) {
        const auto& left = event["time_left"];
        std::cout << "  " << std::left << std::setw(24) << event.value("name", "") << std::setw(36)
                  << event.value("owner", "")
                  << (left.is_null() ? "until unset" : fixed(left.get<double>(), 2) + " s left") << '\n';
    }
    std::cout << "\nconnections:\n";
    const auto connections = answer.value("connections", Value::array());
    if (connections.empty())
        std::cout << "  (none)\n";
    for (const auto& c : connections) {
        const auto& priority = c["priority"];
        const bool wins = priority.is_object() && priority.value("winner", false);
        std::cout << "  " << c.value("source", "") << (wins ? "  <== WINNER" : "")
                  << (c.value("aux", false) ? "  (auxiliary: never delivered)" : "") << '\n';
        std::cout << "      carrier      " << c.value("carrier", "") << '\n';
        const auto& constraint = c["constraint"];
        std::cout << "      constraint   "
                  << (constraint.is_null() ? std::string("none") : constraint.get<std::string>()) << "  = "
                  << (c.value("constraint_value", true) ? "true" : "false") << '\n';
        if (priority.is_object()) {
            std::cout << "      stimulation  S " << fixed(priority.value("S", 0.0), 3) << "  x "
                      << counter(priority, "x") << "  y " << fixed(priority.value("y", 0.0), 3) << '\n';
        }
        std::cout << "      counters     " << counters_line(c.value("counters", Value::object())) << '\n';
    }
    if (check) {
        std::cout << '\n';
        print_overlaps(answer);
    }
}

}  // namespace

int events(const Common& common, const EventsOptions& options) {
    if (auto error = proto::port_name_error(options.port))
        throw Error(ErrorCode::usage, *error);
    auto client = plexus::Client({common.socket});
    proto::EventsRequest asked;
    asked.port = options.port;
    asked.check = options.check;
    const Value request = asked.encode();
    const bool terminal = ::isatty(STDOUT_FILENO) != 0;
    for (long shown = 1;; ++shown) {
        const Value answer = read_as<proto::EventsReply>(client.request(request)).document;
        if (options.json) {
            std::cout << answer.dump() << std::endl;
        } else {
            if (options.watch && terminal)
                std::cout << "\x1b[H\x1b[2J";  // home and clear: redraw in place, like top
            print_text(answer, options.check);
            if (options.watch && !terminal)
                std::cout << '\n';
            std::cout.flush();
        }
        const bool last = !options.watch || (options.count && shown >= *options.count);
        if (last)
            return options.check && !answer.value("overlaps", Value::array()).empty() ? 1 : 0;
        std::this_thread::sleep_for(std::chrono::duration<double>(options.interval));
    }
}

}  // namespace plexus::cli
