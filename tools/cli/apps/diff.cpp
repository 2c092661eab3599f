#include "diff.hpp"

#include "load.hpp"

#include <iostream>

namespace plexus::cli {

int print_diff(const app::App& app, const std::vector<ComponentStep>& components, LiveSystem& live) {
    int differences = 0;
    for (const auto& step : components) {
        if (step.action != ComponentStep::Action::start)
            continue;
        std::cout << "component " << step.component->name << ": not running (" << step.component->label()
                  << ")\n";
        ++differences;
    }
    const auto connections = live.connections();
    for (const auto& step : plan_connections(app, connections)) {
        const auto& c = *step.connection;
        if (step.action == ConnectionStep::Action::make) {
            std::cout << "connection " << c.source << " -> " << c.destination << ": missing (connections["
                      << c.index << "])\n";
            ++differences;
        } else if (step.action == ConnectionStep::Action::replace) {
            std::cout << "connection " << c.source << " -> " << c.destination << ": carrier "
                      << step.live->carrier << ", the file has "
                      << (c.carrier.empty() ? "none (local or tcp)" : c.carrier) << " (connections["
                      << c.index << "])\n";
            ++differences;
        }
    }
    for (const auto& c : foreign_connections(app, connections)) {
        std::cout << "connection " << c.source << " -> " << c.destination << ": not in the file (carrier "
                  << c.carrier << ")\n";
        ++differences;
    }
    if (differences == 0) {
        std::cout << "application '" << app.name << "': no drift (" << counted(components.size(), "component")
                  << ", " << counted(app.connections.size(), "connection") << " as the file says)\n";
        return 0;
    }
    std::cout << "application '" << app.name << "': " << differences
              << (differences == 1 ? " difference" : " differences") << " (`plexus up " << app.file
              << "` repairs what the file has)\n";
    return 1;
}

}  // namespace plexus::cli
