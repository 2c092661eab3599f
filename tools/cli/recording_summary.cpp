#include "recording_summary.hpp"

#include <iomanip>
#include <iostream>

#include "plexus/recording.hpp"

namespace plexus::cli {

int recording_info(const std::string& file, bool json) {
    const auto recording = Recording::open(file);
    // Every chunk is read once, so that a damaged one is reported here (with its offset) rather
    // than halfway through a replay.
    std::uint64_t readable = 0;
    recording.for_each([&readable](const RecordedMessage&) {
        ++readable;
        return true;
    });
    const auto connections = recording.connections();
    const auto end = recording.end_note();
    const double span = recording.end_ns() > recording.start_ns()
                            ? static_cast<double>(recording.end_ns() - recording.start_ns()) * 1e-9
                            : 0.0;
    if (json) {
        Value out{{"file", file},
                  {"node", recording.node()},
                  {"bytes", recording.size_bytes()},
                  {"messages", recording.message_count()},
                  {"start_ns", recording.start_ns()},
                  {"end_ns", recording.end_ns()},
                  {"seconds", span},
                  {"ports", recording.ports()},
                  {"complete", !end.empty()}};
        Value listed = Value::array();
        for (const auto& c : connections)
            listed.push_back(
                {{"port", c.port}, {"source", c.source}, {"carrier", c.carrier}, {"messages", c.messages}});
        out["connections"] = std::move(listed);
        Value note = Value::object();
        for (const auto& [key, value] : end)
            note[key] = value;
        out["end"] = std::move(note);
        std::cout << out.dump() << '\n';
        return 0;
    }
    std::cout << "file      " << file << " (" << recording.size_bytes() << " bytes)\n"
              << "node      " << recording.node() << '\n'
              << "messages  " << recording.message_count() << " over " << std::fixed << std::setprecision(3)
              << span << " s\n";
    for (const auto& port : recording.ports()) {
        std::cout << "port      " << port << '\n';
        for (const auto& c : connections) {
            if (c.port == port)
                std::cout << "  from " << c.source << "  " << c.messages << " messages  (" << c.carrier
                          << ")\n";
        }
    }
    if (end.empty()) {
        std::cout << "end       none: the daemon stopped while recording (the file was still closed "
                     "valid only if it reads)\n";
    } else {
        auto field = [&end](const char* key) {
            auto found = end.find(key);
            return found == end.end() ? std::string("?") : found->second;
        };
        std::cout << "decisions " << field("decisions") << ", events " << field("events") << '\n'
                  << "lost      " << field("lost_messages") << " messages (" << field("lost_bytes")
                  << " bytes)"
                  << (field("not_recordable") != "0" && field("not_recordable") != "?"
                          ? ", " + field("not_recordable") + " in shared memory"
                          : std::string{})
                  << '\n'
                  << "ended     " << field("reason") << '\n';
    }
    return 0;
}

}  // namespace plexus::cli
