// `plexus record PORT... -o FILE.mcap`: asks the local daemon to record its ports into FILE (the
// daemon writes it: no payload passes through this process), shows progress, and stops the
// recording on Ctrl-C, after --duration, or when the daemon ends it (size limit, full disk).
// `plexus record --info FILE`: what a recording holds.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "plexus/proto/operations.hpp"
#include "recording_summary.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

std::atomic<bool> interrupted{false};
extern "C" void note_interrupt(int) {
    interrupted.store(true);
}

/// Ctrl-C and SIGTERM end the recording cleanly instead of killing this process: the daemon
/// would close the file either way (the recording ends with its client), but then nobody would
/// print what it kept.
void catch_interrupts() {
    std::signal(SIGINT, note_interrupt);
    std::signal(SIGTERM, note_interrupt);
}

std::uint64_t count(const Value& document, const char* key) {
    const auto found = document.find(key);
    return found != document.end() && found->is_number_unsigned() ? found->get<std::uint64_t>() : 0;
}

std::string text(const Value& document, const char* key) {
    const auto found = document.find(key);
    return found != document.end() && found->is_string() ? found->get<std::string>() : std::string{};
}

void print_summary(const Value& status, bool json) {
    if (json) {
        std::cout << status.dump() << '\n';
        return;
    }
    std::cout << "recorded " << count(status, "messages") << " messages, " << count(status, "decisions")
              << " decisions, " << count(status, "events") << " events; " << count(status, "bytes")
              << " bytes in";
    for (const auto& file : status.value("files", Value::array()))
        std::cout << ' ' << file.get<std::string>();
    std::cout << '\n';
    if (const auto lost = count(status, "lost_messages"); lost > 0)
        std::cerr
            << "plexus: " << lost << " messages (" << count(status, "lost_bytes")
            << " bytes) could not be kept: the disk did not keep up or was full (see the daemon's log)\n";
    if (const auto shared = count(status, "not_recordable"); shared > 0)
        std::cerr << "plexus: " << shared
                  << " messages were in a writer's shared memory and are not in the file\n";
}

/// plexus-YYYYmmdd-HHMMSS.mcap (UTC), in the current directory, as rosbag2 names its bags.
std::string default_file_name() {
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char name[64];
    std::strftime(name, sizeof name, "plexus-%Y%m%d-%H%M%S.mcap", &utc);
    return name;
}

/// One daemon's part of a recording: the ports it hosts and the file it writes.
struct NodeRecording {
    std::string node;
    std::vector<std::string> ports;
    std::string path;
    std::uint64_t id = 0;
    std::string route;  ///< a port of it: status and stop go to the daemon that hosts it
};

/// PATH for the local node's ports; PATH-STEM.NODE.mcap for another node's (written there).
std::string path_for(const std::string& path, const std::string& node, bool local) {
    if (local)
        return path;
    std::string stem = path;
    if (stem.size() > 5 && stem.ends_with(".mcap"))
        stem.resize(stem.size() - 5);
    return stem + "." + node + ".mcap";
}

/// The ports grouped by the node that hosts them (the daemon there records them).
std::vector<NodeRecording> plan(Client& client, const RecordOptions& options, const std::string& output) {
    const auto local = read_as<proto::NodeReply>(client.request(proto::NodeRequest{}.encode())).node;
    std::vector<NodeRecording> parts;
    if (options.all)
        parts.push_back({local, {}, output, 0, ""});
    for (const auto& port : options.ports) {
        proto::PingRequest asked;
        asked.port = port;
        const auto where = read_as<proto::PingReply>(client.request(asked.encode()));
        auto part =
            std::find_if(parts.begin(), parts.end(), [&](const auto& p) { return p.node == where.node; });
        if (part == parts.end()) {
            parts.push_back({where.node, {}, path_for(output, where.node, where.node == local), 0, port});
            part = std::prev(parts.end());
        }
        part->ports.push_back(port);
        if (part->route.empty() && where.node != local)
            part->route = port;
    }
    return parts;
}

}  // namespace

int record(const Common& common, const RecordOptions& options) {
    if (!options.info.empty())
        return recording_info(options.info, options.json);
    auto client = plexus::Client({common.socket});
    if (options.ports.empty() && !options.all)
        throw Error(ErrorCode::usage, "record needs at least one PORT, or --all");
    // The daemons write the files: they get the path as this shell means it.
    const std::string output =
        std::filesystem::absolute(options.output.empty() ? default_file_name() : options.output)
            .lexically_normal()
            .string();
    catch_interrupts();
    auto parts = plan(client, options, output);
    for (auto& part : parts) {
        proto::RecordStartRequest asked;
        asked.ports = part.ports;
        asked.all = options.all && part.route.empty() && part.ports.empty();
        asked.path = part.path;
        asked.max_bytes = options.max_bytes;
        asked.split_bytes = options.split_bytes;
        const auto started = read_as<proto::RecordStartReply>(client.request(asked.encode()));
        part.id = started.id;
        part.ports = started.ports;
        std::cerr << "recording";
        for (const auto& port : started.ports)
            std::cerr << ' ' << port;
        std::cerr << " into " << part.path << (part.route.empty() ? "" : " on node '" + part.node + "'")
                  << (parts.size() > 1 ? "" : " (Ctrl-C stops)") << '\n';
    }
    if (parts.size() > 1)
        std::cerr << "each node's daemon writes its own file on its own machine (Ctrl-C stops)\n";

    const auto begun = std::chrono::steady_clock::now();
    auto next_look = begun;
    std::string ended_by;
    while (!interrupted.load() && ended_by.empty()) {
        const auto now = std::chrono::steady_clock::now();
        if (options.duration && now - begun >= std::chrono::duration<double>(*options.duration))
            break;
        if (now >= next_look) {
            // Asking also keeps another node's recording alive: it ends if nobody asks for 5 s.
            for (const auto& part : parts) {
                proto::RecordStatusRequest asked;
                asked.id = part.id;
                asked.port = part.route;
                const auto status = read_as<proto::RecordStatusReply>(client.request(asked.encode()));
                if (status.document.value("ended", false))
                    ended_by = text(status.document, "reason");
            }
            next_look = now + std::chrono::milliseconds(500);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    int status = 0;
    for (const auto& part : parts) {
        proto::RecordStopRequest asked;
        asked.id = part.id;
        asked.port = part.route;
        const auto stopped = read_as<proto::RecordStatusReply>(client.request(asked.encode()));
        print_summary(stopped.document, options.json);
        const std::string error = text(stopped.document, "error");
        if (!error.empty()) {
            std::cerr << "plexus: the recording stopped early: " << error
                      << " (the file holds what was written before, and is complete)\n";
            status = 1;
        }
    }
    if (!ended_by.empty() && status == 0)
        std::cerr << "plexus: the recording ended: " << ended_by << '\n';
    return status;
}

}  // namespace plexus::cli
