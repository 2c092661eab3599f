#include "commands.hpp"

#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <thread>

#include "counter.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/port_name.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

using Clock = std::chrono::steady_clock;

plexus::Client make_client(const Common& common) {
    return plexus::Client({common.socket});
}

void require_port_name(const std::string& name) {
    if (auto error = proto::port_name_error(name))
        throw Error(ErrorCode::usage, *error);
}

/// True when stdin has nothing more to read right now: the moment to send what is buffered.
bool stdin_idle() {
    if (std::cin.rdbuf()->in_avail() > 0)
        return false;
    pollfd in{STDIN_FILENO, POLLIN, 0};
    return ::poll(&in, 1, 0) == 0;
}

std::string pad(const std::string& text, std::size_t width) {
    return text.size() >= width ? text + " " : text + std::string(width - text.size(), ' ');
}

void print_monitors(const Value& connection) {
    for (const auto& m : connection.value("monitors", Value::array())) {
        std::cout << "         monitor " << m.value("script", "") << " (" << m.value("side", "")
                  << "): " << counter(m, "messages") << " messages, " << counter(m, "dropped") << " dropped, "
                  << counter(m, "rewritten") << " rewritten, " << counter(m, "errors") << " errors ("
                  << counter(m, "timeouts") << " timeouts, " << counter(m, "out_of_memory")
                  << " out of memory), " << counter(m, "memory_bytes") << " bytes";
        if (m.value("quarantined", false))
            std::cout << "  QUARANTINED: " << m.value("last_error", "");
        std::cout << '\n';
    }
}

}  // namespace

const NamesLocation& Common::names_choice() const {
    if (!found_)
        found_ = find_names(names_flag);
    return *found_;
}

int where(const Common& common) {
    const auto& found = common.names_choice();
    std::cout << found.address << " (" << found.how << ")\n";
    return 0;
}

int list(const Common& common, bool json) {
    const Value answer =
        read_as<proto::ListReply>(
            Client::ask_names(common.names(), proto::ListRequest{}.encode()).value_or(Value::object()))
            .document;
    if (json) {
        std::cout << answer.dump() << '\n';
        return 0;
    }
    std::cout << pad("PORT", 32) << pad("NODE", 16) << "ADDRESS\n";
    for (const auto& port : answer.value("ports", Value::array())) {
        std::cout << pad(port.value("name", ""), 32) << pad(port.value("node", ""), 16)
                  << port.value("address", "") << '\n';
    }
    const auto connections = answer.value("connections", Value::array());
    if (!connections.empty()) {
        std::cout << '\n' << pad("CONNECTION", 48) << pad("CARRIER", 16) << "STATE\n";
        for (const auto& c : connections) {
            std::string state = c.value("live", false) ? "up" : "waiting";
            if (c.value("persistent", false))
                state += ", persistent";
            std::cout << pad(c.value("source", "") + " -> " + c.value("destination", ""), 48)
                      << pad(c.value("carrier", ""), 16) << state << '\n';
        }
    }
    return 0;
}

int connect(const Common& common, const std::string& source, const std::string& destination,
            const std::string& carrier, bool persist, bool strict) {
    require_port_name(source);
    require_port_name(destination);
    auto client = make_client(common);
    proto::ConnectRequest asked;
    asked.source = source;
    asked.destination = destination;
    asked.carrier = carrier;
    asked.persist = persist;
    asked.strict = strict;
    const auto reply = read_as<proto::ConnectReply>(client.request(asked.encode()));
    for (const auto& warning : reply.warnings)
        std::cerr << "warning: " << warning << '\n';
    std::cerr << "connected " << source << " -> " << destination << " ("
              << (reply.carrier.empty() ? carrier : reply.carrier) << ")\n";
    return 0;
}

int disconnect(const Common& common, const std::string& source, const std::string& destination) {
    require_port_name(source);
    require_port_name(destination);
    auto client = make_client(common);
    client.disconnect(source, destination);
    return 0;
}

int write(const Common& common, const std::string& port_name, const std::vector<std::string>& destinations) {
    require_port_name(port_name);
    for (const auto& d : destinations)
        require_port_name(d);
    auto client = make_client(common);
    auto port = client.open(port_name);
    for (const auto& destination : destinations)
        client.connect(port_name, destination);
    // Someone typing at a terminal otherwise sees nothing happen; a pipe's reader wants nothing
    // extra on stderr.
    if (::isatty(STDIN_FILENO) != 0) {
        std::cerr << "plexus: opened " << port_name;
        for (const auto& destination : destinations)
            std::cerr << ", connected " << port_name << " -> " << destination;
        std::cerr << "; type one message per line (JSON if it parses, else a string), Ctrl-D to end\n";
    }
    std::ios::sync_with_stdio(false);
    std::string line;
    long line_number = 0;
    while (std::getline(std::cin, line)) {
        ++line_number;
        Value value = Value::parse(line, nullptr, false);
        if (value.is_discarded())
            value = line;
        try {
            // Batch while stdin has more ready; send as soon as it goes quiet (interactive use).
            port.write(value, stdin_idle());
        } catch (const Error& e) {
            // A line that can never be sent (too large, too deep) ends the run with its reason;
            // the lines before it were written and are flushed as the port closes.
            throw Error(e.code(), "line " + std::to_string(line_number) + ": " + e.what());
        }
    }
    port.close();  // flushes, and the daemon has routed everything before it answers
    return 0;
}

int read(const Common& common, const ReadOptions& options) {
    require_port_name(options.port);
    if (!options.source.empty())
        require_port_name(options.source);
    auto client = make_client(common);
    PortOptions port_options;
    port_options.policy = options.policy == "latest" ? QueuePolicy::latest : QueuePolicy::strict;
    port_options.capacity = options.capacity;
    auto port = client.open(options.port, port_options);
    if (!options.source.empty())
        client.connect(options.source, options.port, options.carrier);
    const auto deadline = options.timeout
                              ? Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                   std::chrono::duration<double>(*options.timeout))
                              : Clock::time_point::max();
    long received = 0;
    std::string out;
    while (!options.count || received < *options.count) {
        const auto now = Clock::now();
        if (now >= deadline) {
            std::fflush(stdout);
            std::cerr << "plexus: timed out after " << received << " messages\n";
            return 3;
        }
        const auto wait = deadline == Clock::time_point::max()
                              ? std::chrono::milliseconds(1000)
                              : std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now) +
                                    std::chrono::milliseconds(1);
        auto message = port.read(std::min(wait, std::chrono::milliseconds(1000)));
        if (!message)
            continue;
        ++received;
        if (options.envelope) {
            out = Value{{"from", message->envelope.source},
                        {"seq", message->envelope.seq},
                        {"time", static_cast<double>(message->envelope.time_ns) / 1e9},
                        {"data", message->data}}
                      .dump(-1, ' ', false, Value::error_handler_t::replace);
        } else {
            out = message->data.dump(-1, ' ', false, Value::error_handler_t::replace);
        }
        out += '\n';
        std::fwrite(out.data(), 1, out.size(), stdout);
        std::fflush(stdout);
    }
    return 0;
}

int exists(const Common& common, const std::string& port, const std::string& destination) {
    require_port_name(port);
    if (destination.empty())
        return Client::ask_names(common.names(), proto::LookupRequest{port}.encode()) ? 0 : 1;
    require_port_name(destination);
    const Value answer =
        read_as<proto::ListReply>(
            Client::ask_names(common.names(), proto::ListRequest{}.encode()).value_or(Value::object()))
            .document;
    for (const auto& c : answer.value("connections", Value::array())) {
        if (c.value("source", "") == port && c.value("destination", "") == destination &&
            c.value("live", false)) {
            return 0;
        }
    }
    return 1;
}

int wait(const Common& common, const std::string& port, double timeout) {
    require_port_name(port);
    const auto start = Clock::now();
    auto pause = std::chrono::milliseconds(10);
    for (;;) {
        try {
            if (Client::ask_names(common.names(), proto::LookupRequest{port}.encode()))
                return 0;
        } catch (const Error& e) {
            // The name server may not be up yet: waiting for it is part of waiting for the port.
            if (e.code() == ErrorCode::usage)
                throw;
        }
        if (timeout > 0 && Clock::now() - start >= std::chrono::duration<double>(timeout)) {
            std::cerr << "plexus: " << port << " did not appear within " << timeout << " s\n";
            return 3;
        }
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::milliseconds(200));
    }
}

int ping(const Common& common, const std::string& port, int count) {
    require_port_name(port);
    auto client = make_client(common);
    Value where;
    std::vector<double> times;
    for (int i = 0; i < count; ++i) {
        const auto start = Clock::now();
        where = client.ping(port);
        times.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
    }
    std::sort(times.begin(), times.end());
    std::cout << port << " is on node '" << where.value("node", "?") << "' at " << where.value("address", "?")
              << ": round trip min " << times.front() << " us, median " << times[times.size() / 2]
              << " us, max " << times.back() << " us (" << count << " pings through the local daemon)\n";
    return 0;
}

int stats(const Common& common, const std::string& port, bool json) {
    if (!port.empty())
        require_port_name(port);
    auto client = make_client(common);
    auto answer = client.stats(port);
    if (json) {
        std::cout << answer.dump() << '\n';
        return 0;
    }
    std::cout << "node '" << answer.value("node", "") << "' at " << answer.value("address", "") << '\n';
    std::cout << pad("PORT", 28) << pad("POLICY", 14) << pad("DEPTH", 8) << pad("WRITTEN", 10)
              << pad("RECEIVED", 10) << pad("DELIVERED", 10) << "DROPPED\n";
    for (const auto& p : answer.value("ports", Value::array())) {
        std::cout << pad(p.value("name", ""), 28)
                  << pad(p.value("policy", "") + "/" + std::to_string(counter(p, "capacity")), 14)
                  << pad(std::to_string(counter(p, "depth")), 8)
                  << pad(std::to_string(counter(p, "written")), 10)
                  << pad(std::to_string(counter(p, "received")), 10)
                  << pad(std::to_string(counter(p, "delivered")), 10) << counter(p, "dropped_queue") << '\n';
        if (counter(p, "unconnected") > 0)
            std::cout << "    written with no connection out (went nowhere): " << counter(p, "unconnected")
                      << '\n';
        // Counters the port's own client reported (a bridge: what it could not convert or deliver).
        const auto reported = p.value("reported", Value::object());
        if (!reported.empty()) {
            std::cout << "    reported by its client:";
            for (const auto& [name, value] : reported.items())
                std::cout << ' ' << name << ' ' << value.dump();
            std::cout << '\n';
        }
        for (const auto& c : p.value("outgoing", Value::array())) {
            std::cout << "    -> " << pad(c.value("destination", ""), 24) << pad(c.value("carrier", ""), 10)
                      << "sent " << counter(c, "sent") << ", dropped by monitors "
                      << counter(c, "dropped_by_monitor") << '\n';
            if (c.contains("udp")) {
                // What the udp carrier did with what the connection sent.
                const auto& udp = c["udp"];
                std::cout << "         udp: " << counter(udp, "messages") << " messages in "
                          << counter(udp, "datagrams") << " datagrams, dropped too large "
                          << counter(udp, "dropped_too_large") << " / not sent (socket full) "
                          << counter(udp, "dropped_send") << '\n';
            }
            print_monitors(c);
        }
        for (const auto& c : p.value("inbound", Value::array())) {
            std::cout << "    <- " << pad(c.value("source", ""), 24) << pad(c.value("carrier", ""), 10)
                      << "received " << counter(c, "received") << ", delivered " << counter(c, "delivered")
                      << ", dropped by accept " << counter(c, "dropped_by_accept") << " / constraint "
                      << counter(c, "dropped_by_constraint") << " / priority "
                      << counter(c, "dropped_by_priority") << " / queue " << counter(c, "dropped_by_queue")
                      << ", script errors " << counter(c, "script_errors") << '\n';
            if (c.contains("lost")) {
                // A datagram carrier (udp): what never arrived whole, or arrived too late or to a
                // full queue.
                std::cout << "         lost " << counter(c, "lost") << " (of which incomplete "
                          << counter(c, "incomplete") << "), late " << counter(c, "late") << ", dropped full "
                          << counter(c, "dropped_full") << '\n';
            }
            print_monitors(c);
        }
    }
    const auto d = answer.value("daemon", Value::object());
    std::cout << "daemon: " << counter(d, "sessions") << " sessions, " << counter(d, "protocol_errors")
              << " protocol errors, " << counter(d, "dropped_unknown_port") << " dropped (port closed), "
              << counter(d, "dropped_link_down") << " dropped (link down)\n";
    std::cout << "shared memory: " << counter(d, "shm_regions") << " regions ("
              << counter(d, "shm_bytes") / (1024 * 1024) << " MiB), " << counter(d, "shm_slots")
              << " payloads held, " << counter(d, "shm_passed") << " passed in place, "
              << counter(d, "shm_copied") << " copied out\n";
    return 0;
}

}  // namespace plexus::cli
