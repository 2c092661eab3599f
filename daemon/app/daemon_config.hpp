#pragma once
// The daemon's settings: apart from daemon.hpp, so that the config file's reader (config_file.hpp)
// and the mains fill them without seeing the daemon's accept loops and sessions.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "control/control_config.hpp"
#include "monitor/monitor_policy.hpp"
#include "net/daemon_counters.hpp"
#include "plexus/proto/endpoint.hpp"
#include "web/http_config.hpp"

namespace plexus::daemon {

/// Everything plexusd is told (command line, config file). Each layer reads its own part through
/// the base it is handed: net/ a NetConfig, control/ a ControlConfig (control/control_config.hpp).
struct DaemonConfig : ControlConfig {
    bool embedded_names = false;
    std::string names_state;  ///< state file of the embedded name server
    proto::Endpoint listen{"127.0.0.1", 0};
    /// The host other daemons reach this one at (--advertise); empty: the --listen host, or, when
    /// that is 0.0.0.0 or ::, the address the name server sees this daemon's session come from.
    std::string advertise;
    std::string socket_path;
    std::vector<std::string> script_dirs;
    /// Directories of compiled monitors (type.so): the only places a plugin is loaded from.
    std::vector<std::string> monitor_lib_dirs;
    std::string ready_file;  ///< written (JSON: node, address, socket, names) once registered
    std::chrono::milliseconds names_grace{2000};
    monitor::MonitorPolicy monitors;  ///< memory cap, time budget, quarantine of every port monitor
    std::size_t monitor_threads = 0;  ///< worker threads for monitors; 0: one per core
    web::HttpConfig http;             ///< the web endpoint (--http); off unless it has an address
};

}  // namespace plexus::daemon
