// `plexus up FILE`: start the components that are not running, wait for their ports, make the
// connections that are missing. Idempotent; undoes itself when it fails midway.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <set>
#include <thread>

#include "app_commands.hpp"
#include "command_path.hpp"
#include "component_process.hpp"
#include "diff.hpp"
#include "load.hpp"
#include "plan.hpp"

namespace plexus::cli {

namespace {

using Clock = std::chrono::steady_clock;

std::string names_of(const std::vector<std::string>& names) {
    std::string out;
    for (const auto& name : names)
        out += (out.empty() ? "" : ", ") + name;
    return names.empty() ? "" : " (" + out + ")";
}

/// What this `up` changed, so that a failure midway leaves the system as it found it.
class Undo {
public:
    Undo(LiveSystem& live, AppState& state, std::string state_file)
        : live_(live), state_(state), state_file_(std::move(state_file)) {}

    void started(const std::string& name) { started_.push_back(name); }
    void made(const app::AppConnection& c) { made_.push_back(&c); }
    void replaced(const app::AppConnection& c, const LiveConnection& before) {
        replaced_.push_back({&c, before});
    }

    /// Reverses everything, newest first; says what it did on stderr.
    void run() {
        for (auto it = replaced_.rbegin(); it != replaced_.rend(); ++it) {
            try {
                live_.disconnect(it->first->source, it->first->destination);
                live_.connect(it->second.source, it->second.destination, it->second.carrier,
                              it->second.persistent);
                std::cerr << "undo: restored " << it->second.source << " -> " << it->second.destination
                          << " (" << it->second.carrier << ")\n";
            } catch (const std::exception& e) {
                std::cerr << "undo: could not restore " << it->second.source << " -> "
                          << it->second.destination << ": " << e.what() << '\n';
            }
        }
        for (auto it = made_.rbegin(); it != made_.rend(); ++it) {
            try {
                live_.disconnect((*it)->source, (*it)->destination);
                std::cerr << "undo: removed " << (*it)->source << " -> " << (*it)->destination << '\n';
            } catch (const std::exception& e) {
                std::cerr << "undo: could not remove " << (*it)->source << " -> " << (*it)->destination
                          << ": " << e.what() << '\n';
            }
        }
        std::vector<ComponentRecord> records;
        for (const auto& name : started_)
            records.push_back(state_.components.at(name));
        stop_processes(records);
        for (const auto& name : started_) {
            std::cerr << "undo: stopped " << name << " (log " << state_.components.at(name).log << ")\n";
            state_.components.erase(name);
        }
        write_state(state_file_, state_);
    }

private:
    LiveSystem& live_;
    AppState& state_;
    std::string state_file_;
    std::vector<std::string> started_;
    std::vector<const app::AppConnection*> made_;
    std::vector<std::pair<const app::AppConnection*, LiveConnection>> replaced_;
};

/// A failure after something changed: undo, then the exit status.
int fail(Undo& undo, int status, const std::string& reason) {
    std::cerr << "plexus: " << reason << "\n";
    undo.run();
    std::cerr << "plexus: up failed; what it had done is undone\n";
    return status;
}

/// Waits for `ports`; none on success, else the ports still missing. Fails early when a
/// component this `up` started exits.
struct Waited {
    std::vector<std::string> missing;
    std::optional<std::string> exited;  ///< "component X exited with status N"
};

Waited wait_for_ports(LiveSystem& live, std::vector<std::string> ports, double timeout,
                      const std::vector<std::pair<std::string, pid_t>>& started) {
    const auto deadline =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout));
    auto pause = std::chrono::milliseconds(10);
    for (;;) {
        std::erase_if(ports, [&](const std::string& port) { return live.port_exists(port); });
        if (ports.empty())
            return {};
        for (const auto& [name, pid] : started) {
            if (auto status = exited_child(pid))
                return {ports, "component " + name + " exited with status " + std::to_string(*status) +
                                   " before its ports appeared"};
        }
        if (Clock::now() >= deadline)
            return {ports, std::nullopt};
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::milliseconds(200));
    }
}

}  // namespace

int up(const Common& common, const UpOptions& options) {
    auto app = load_checked_app(options.file);
    if (!app) {
        std::cerr << "plexus: nothing was started or connected\n";
        return 2;
    }
    for (const auto& [node, socket] : options.node_sockets) {
        std::error_code ec;
        if (!std::filesystem::exists(socket, ec)) {
            std::cerr << "plexus: --node-socket " << node << "=" << socket << ": no such socket\n";
            return 2;
        }
    }
    LiveSystem live(common.socket);
    Where where{common.socket, live.node(), options.node_sockets, options.only_node};
    const std::string state_file = state_path(common.socket, app->name);
    AppState state = read_state(state_file);
    state.file = std::filesystem::absolute(options.file).lexically_normal().string();

    std::vector<std::string> problems;
    auto components = plan_components(*app, where, state, live, problems);
    std::map<std::string, std::string> programs;
    for (const auto& step : components) {
        if (step.action != ComponentStep::Action::start || options.diff)
            continue;
        if (auto program = app::find_command(step.component->command, app->directory))
            programs[step.component->name] = *program;
        else
            problems.push_back(app->file + ": " + step.component->label() + ": \"command\": " +
                               app::command_search_text(step.component->command, app->directory));
    }
    if (!problems.empty()) {
        for (const auto& problem : problems)
            std::cerr << problem << '\n';
        std::cerr << "plexus: nothing was started or connected\n";
        return 2;
    }
    if (options.diff)
        return print_diff(*app, components, live);

    Undo undo(live, state, state_file);
    std::vector<std::string> started;
    std::vector<std::string> running;
    std::vector<std::pair<std::string, pid_t>> started_pids;
    std::vector<std::string> ports;
    for (const auto& step : components) {
        const auto& component = *step.component;
        if (step.action == ComponentStep::Action::other_node)
            continue;
        ports.insert(ports.end(), component.ports.begin(), component.ports.end());
        if (step.action != ComponentStep::Action::start) {
            running.push_back(component.name);
            continue;
        }
        Launch launch{programs.at(component.name), component.args, component.env,
                      log_path(common.socket, app->name, component.name)};
        launch.env["PLEXUS_SOCKET"] = step.socket;
        if (common.names_flag)
            launch.env["PLEXUS_NAMES"] = *common.names_flag;
        auto record = start_process(launch);
        if (!record)
            return fail(undo, 4, component.label() + ": " + record.error().message);
        record->node = step.node;
        record->socket = step.socket;
        state.components[component.name] = *record;
        // Recorded at once: if this `up` is killed, `down` still finds what it started.
        write_state(state_file, state);
        undo.started(component.name);
        started.push_back(component.name);
        started_pids.emplace_back(component.name, record->pid);
        std::cerr << "started " << component.name << " (pid " << record->pid << ", log " << record->log
                  << ")\n";
    }
    if (!options.only_node)
        ports.insert(ports.end(), app->wait.begin(), app->wait.end());

    auto waited = wait_for_ports(live, ports, options.timeout, started_pids);
    if (!waited.missing.empty()) {
        std::string reason =
            waited.exited ? *waited.exited + "; missing:"
                          : "timed out after " + std::to_string(options.timeout) + " s waiting for ports:";
        for (const auto& port : waited.missing) {
            reason += "\n    " + port;
            for (const auto& component : app->components) {
                const auto& claimed = component.ports;
                if (std::find(claimed.begin(), claimed.end(), port) == claimed.end())
                    continue;
                reason += " (of component " + component.name;
                if (auto it = state.components.find(component.name); it != state.components.end())
                    reason += "; see its log " + it->second.log;
                reason += ")";
            }
        }
        return fail(undo, waited.exited ? 4 : 3, reason);
    }

    int made = 0;
    int present = 0;
    int replaced = 0;
    std::vector<std::string> deferred;
    for (const auto& step : plan_connections(*app, live.connections())) {
        const auto& c = *step.connection;
        if (step.action == ConnectionStep::Action::present) {
            ++present;
            continue;
        }
        if (options.only_node && (!live.port_exists(c.source) || !live.port_exists(c.destination))) {
            // The other end belongs to another node's `up --only-node`: it makes this one later.
            deferred.push_back(c.source + " -> " + c.destination);
            continue;
        }
        try {
            if (step.action == ConnectionStep::Action::replace) {
                live.disconnect(c.source, c.destination);
                undo.replaced(c, *step.live);
                std::cerr << "replacing " << c.source << " -> " << c.destination << ": carrier was "
                          << step.live->carrier << ", the file has "
                          << (c.carrier.empty() ? "none" : c.carrier) << '\n';
            }
            for (const auto& warning : live.connect(c.source, c.destination, c.carrier, c.persist))
                std::cerr << "warning: " << c.label() << ": " << warning << '\n';
            if (step.action == ConnectionStep::Action::make) {
                undo.made(c);
                ++made;
            } else {
                ++replaced;
            }
        } catch (const Error& e) {
            return fail(undo, 4, app->file + ": " + c.label() + ": refused: " + e.what());
        }
    }

    std::cout << "application '" << app->name << "': components: started " << started.size()
              << names_of(started) << ", already running " << running.size() << names_of(running)
              << "; connections: made " << made << ", already there " << present << ", replaced " << replaced;
    if (!deferred.empty())
        std::cout << ", left for the other nodes' `up --only-node` " << deferred.size() << names_of(deferred);
    std::cout << (started.empty() && made == 0 && replaced == 0 ? " (nothing to do)" : "") << '\n';
    return 0;
}

}  // namespace plexus::cli
