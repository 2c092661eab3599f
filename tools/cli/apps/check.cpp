// `plexus check FILE`: validates an application without touching the system (no daemon needed).
#include <iostream>

#include "app_commands.hpp"
#include "load.hpp"

namespace plexus::cli {

int check_app_file(const std::string& file) {
    auto app = load_checked_app(file);
    if (!app)
        return 2;
    std::size_t ports = app->wait.size();
    for (const auto& component : app->components)
        ports += component.ports.size();
    std::cout << file << ": application '" << app->name
              << "' is consistent: " << counted(app->components.size(), "component") << ", "
              << counted(app->connections.size(), "connection") << ", " << counted(ports, "port")
              << " to wait for\n";
    return 0;
}

}  // namespace plexus::cli
