// `plexus record PORT... -o FILE.mcap`: asks the local daemon to record its ports into FILE (the
// daemon writes it: no payload passes through this process), shows progress, and stops the
// recording on Ctrl-C, after --duration, or when the daemon ends it (size limit, full disk).
// `plexus record --info FILE`: what a recording holds.
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <thread>

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

}  // namespace

int record(const Common& common, const RecordOptions& options) {
    if (!options.info.empty())
        return recording_info(options.info, options.json);
    if (options.output.empty())
        throw Error(ErrorCode::usage, "record needs -o FILE.mcap (or --info FILE)");
    if (options.ports.empty() && !options.all)
        throw Error(ErrorCode::usage, "record needs at least one PORT, or --all");
    proto::RecordStartRequest asked;
    asked.ports = options.ports;
    asked.all = options.all;
    // The daemon writes the file: it gets the path as this shell means it.
    asked.path = std::filesystem::absolute(options.output).lexically_normal().string();
    asked.max_bytes = options.max_bytes;
    asked.split_bytes = options.split_bytes;
    auto client = plexus::Client({common.socket});
    catch_interrupts();
    const auto started = read_as<proto::RecordStartReply>(client.request(asked.encode()));
    std::cerr << "recording";
    for (const auto& port : started.ports)
        std::cerr << ' ' << port;
    std::cerr << " into " << asked.path << " (Ctrl-C stops)\n";

    const auto begun = std::chrono::steady_clock::now();
    auto next_look = begun;
    std::string ended_by;
    while (!interrupted.load()) {
        const auto now = std::chrono::steady_clock::now();
        if (options.duration && now - begun >= std::chrono::duration<double>(*options.duration))
            break;
        if (now >= next_look) {
            const auto status = read_as<proto::RecordStatusReply>(
                client.request(proto::RecordStatusRequest{started.id}.encode()));
            if (status.document.value("ended", false)) {
                ended_by = text(status.document, "reason");
                break;
            }
            next_look = now + std::chrono::milliseconds(500);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const auto stopped =
        read_as<proto::RecordStatusReply>(client.request(proto::RecordStopRequest{started.id}.encode()));
    print_summary(stopped.document, options.json);
    const std::string error = text(stopped.document, "error");
    if (!error.empty()) {
        std::cerr << "plexus: the recording stopped early: " << error
                  << " (the file holds what was written before, and is complete)\n";
        return 1;
    }
    if (!ended_by.empty())
        std::cerr << "plexus: the recording ended: " << ended_by << '\n';
    return 0;
}

}  // namespace plexus::cli
