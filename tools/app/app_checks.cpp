#include "app_checks.hpp"

#include <set>

#include "command_path.hpp"

namespace plexus::app {

CheckReport check_app(const App& app) {
    CheckReport report;
    check_duplicates(app, report);
    const auto carriers = check_carriers(app, report);
    check_arbitration(app, carriers, report);
    check_commands(app, report);
    return report;
}

void check_duplicates(const App& app, CheckReport& report) {
    std::map<std::string, const Component*> names;
    std::map<std::string, const Component*> claimed;
    for (const auto& component : app.components) {
        if (auto [it, fresh] = names.emplace(component.name, &component); !fresh)
            report.problems.push_back(app.file + ": " + component.label() +
                                      ": \"name\": " + it->second->label() + " has the same name");
        std::set<std::string> own;
        for (const auto& port : component.ports) {
            if (!own.insert(port).second) {
                report.problems.push_back(app.file + ": " + component.label() + ": \"ports\": " + port +
                                          " is named twice");
                continue;
            }
            if (auto [it, fresh] = claimed.emplace(port, &component); !fresh)
                report.problems.push_back(app.file + ": " + component.label() + ": \"ports\": " + port +
                                          " is also claimed by " + it->second->label() +
                                          " (one port, one component)");
        }
    }
    std::map<std::pair<std::string, std::string>, const AppConnection*> seen;
    for (const auto& connection : app.connections) {
        const auto key = std::make_pair(connection.source, connection.destination);
        if (auto [it, fresh] = seen.emplace(key, &connection); !fresh)
            report.problems.push_back(app.file + ": " + connection.label() + ": the same connection as " +
                                      it->second->label() + " (two ports are joined at most once)");
    }
}

void check_commands(const App& app, CheckReport& report) {
    for (const auto& component : app.components) {
        if (!find_command(component.command, app.directory))
            report.warnings.push_back(app.file + ": " + component.label() + ": \"command\": " +
                                      command_search_text(component.command, app.directory));
    }
}

}  // namespace plexus::app
