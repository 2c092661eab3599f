// `plexus down FILE`: removes the file's connections, then stops what `up` started. Connections go
// first, while their ports still exist, so that a persistent one is forgotten by the name server
// instead of waiting for its ports to return.
#include <filesystem>
#include <iostream>

#include "app_commands.hpp"
#include "component_process.hpp"
#include "live_system.hpp"
#include "load.hpp"

namespace plexus::cli {

int down(const Common& common, const std::string& file) {
    // The schema only: a carrier that no longer checks must not keep its connection alive.
    auto app = load_checked_app(file, false);
    if (!app)
        return 2;
    int status = 0;
    int removed = 0;
    try {
        LiveSystem live(common.socket);
        const auto connections = live.connections();
        for (const auto& c : app->connections) {
            if (!LiveSystem::find(connections, c.source, c.destination))
                continue;
            try {
                live.disconnect(c.source, c.destination);
                std::cerr << "removed " << c.source << " -> " << c.destination << '\n';
                ++removed;
            } catch (const Error& e) {
                std::cerr << "plexus: " << c.label() << ": could not remove it: " << e.what() << '\n';
                status = 4;
            }
        }
    } catch (const Error& e) {
        // Stop the components all the same: what this machine runs is ours to stop.
        std::cerr << "plexus: connections not removed: " << e.what() << '\n';
        status = 4;
    }

    const std::string state_file = state_path(common.socket, app->name);
    AppState state = read_state(state_file);
    std::vector<std::string> names;
    std::vector<ComponentRecord> records;
    for (const auto& [name, record] : state.components) {
        names.push_back(name);
        records.push_back(record);
    }
    const auto stopped = stop_processes(records);
    int stopped_count = 0;
    for (std::size_t i = 0; i < names.size(); ++i) {
        switch (stopped[i]) {
            case Stopped::terminated:
                std::cerr << "stopped " << names[i] << " (pid " << records[i].pid << ")\n";
                ++stopped_count;
                break;
            case Stopped::killed:
                std::cerr << "killed " << names[i] << " (pid " << records[i].pid
                          << "): still running 5 s after SIGTERM\n";
                ++stopped_count;
                break;
            case Stopped::gone:
                std::cerr << names[i] << " was not running any more (pid " << records[i].pid << ")\n";
                break;
        }
    }
    std::error_code ec;
    std::filesystem::remove(state_file, ec);
    std::cout << "application '" << app->name << "': removed " << counted(removed, "connection")
              << ", stopped " << counted(stopped_count, "component")
              << (removed == 0 && stopped_count == 0 ? " (nothing was up)" : "") << '\n';
    return status;
}

}  // namespace plexus::cli
