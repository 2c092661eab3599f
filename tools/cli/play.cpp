// `plexus play FILE.mcap`: writes the recorded sources' messages again, with their original
// timing, from ports of the recorded sources' names (or --remap'ed ones) opened on the local
// daemon: they go wherever the connections that exist now take them.
#include <atomic>
#include <chrono>
#include <csignal>
#include <iostream>
#include <map>
#include <thread>

#include "commands.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/recording.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

std::atomic<bool> stop_playing{false};
extern "C" void note_stop(int) {
    stop_playing.store(true);
}

/// "/a=/b" pairs as a map; a malformed one is a usage error.
std::map<std::string, std::string> remaps_of(const std::vector<std::string>& pairs) {
    std::map<std::string, std::string> out;
    for (const auto& pair : pairs) {
        const auto equal = pair.find('=');
        if (equal == std::string::npos || equal == 0 || equal + 1 == pair.size())
            throw Error(ErrorCode::usage, "--remap takes OLD=NEW port names, not '" + pair + "'");
        out[pair.substr(0, equal)] = pair.substr(equal + 1);
    }
    return out;
}

/// Whether the daemon has made a connection out of `port` yet (a persistent connection is made
/// again when its source port comes back).
bool has_connections(Client& client, const std::string& port) {
    proto::StatsRequest asked;
    asked.port = port;
    const auto stats = read_as<proto::StatsReply>(client.request(asked.encode()));
    for (const auto& entry : stats.document.value("ports", Value::array())) {
        if (entry.value("name", std::string{}) == port)
            return !entry.value("outgoing", Value::array()).empty();
    }
    return false;
}

}  // namespace

int play(const Common& common, const PlayOptions& options) {
    if (!(options.rate > 0))
        throw Error(ErrorCode::usage, "--rate must be more than 0");
    const auto remaps = remaps_of(options.remaps);
    const auto recording = Recording::open(options.file);
    // A source that reached several recorded ports was recorded once per port: play it once, from
    // the first recorded port it reached.
    std::map<std::string, std::string> source_port;
    for (const auto& c : recording.connections()) {
        if (!options.ports.empty() &&
            std::find(options.ports.begin(), options.ports.end(), c.port) == options.ports.end())
            continue;
        source_port.emplace(c.source, c.port);
    }
    if (source_port.empty())
        throw Error(ErrorCode::usage, options.file + " holds no message for the ports asked");
    auto client = plexus::Client({common.socket});
    std::map<std::string, Port> ports;
    for (const auto& [source, port] : source_port) {
        const auto remapped = remaps.find(source);
        const std::string name = remapped == remaps.end() ? source : remapped->second;
        ports.emplace(source, client.open(name));
    }
    // Wait (bounded) for the connections out of them: persistent ones come back with their ports.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(options.wait);
    for (const auto& [source, port] : ports) {
        while (!has_connections(client, port.name()) && std::chrono::steady_clock::now() < deadline)
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        if (!has_connections(client, port.name()))
            std::cerr << "plexus: no connection out of " << port.name() << " yet: its messages go nowhere\n";
    }
    std::signal(SIGINT, note_stop);
    std::signal(SIGTERM, note_stop);
    const std::uint64_t origin = recording.start_ns();
    const auto from_ns = static_cast<std::uint64_t>(options.start * 1e9);
    const auto until_ns = options.end ? static_cast<std::uint64_t>(*options.end * 1e9) : UINT64_MAX;
    std::uint64_t played = 0;
    do {
        const auto began = std::chrono::steady_clock::now();
        std::uint64_t first_ns = 0;
        recording.for_each([&](const RecordedMessage& message) {
            if (stop_playing.load())
                return false;
            auto target = source_port.find(message.source);
            if (target == source_port.end() || target->second != message.port)
                return true;
            const std::uint64_t at = message.arrived_ns >= origin ? message.arrived_ns - origin : 0;
            if (at < from_ns)
                return true;
            if (at > until_ns)
                return false;
            if (first_ns == 0)
                first_ns = at == 0 ? 1 : at;
            // The recorded spacing of arrivals, scaled by --rate, from the first message played.
            const double offset = static_cast<double>(at - std::min(at, first_ns)) * 1e-9 / options.rate;
            std::this_thread::sleep_until(began +
                                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                              std::chrono::duration<double>(offset)));
            ports.at(message.source).write_encoded(message.payload);
            ++played;
            return true;
        });
    } while (options.loop && !stop_playing.load());
    for (auto& [source, port] : ports)
        port.close();  // flushes
    std::cerr << "played " << played << " messages from " << ports.size() << " sources\n";
    return 0;
}

}  // namespace plexus::cli
