#pragma once
// `plexus check / up / down` (docs/APPLICATIONS.md). Each returns the exit status of DESIGN's
// contract: 0 success, 1 drift found (`up --diff`), 2 a bad file or usage, 3 timeout, 4 refused
// or failed midway (what that `up` did is undone first).

#include <map>
#include <optional>
#include <string>

#include "../commands.hpp"

namespace plexus::cli {

struct UpOptions {
    std::string file;
    bool diff = false;                                ///< report drift, change nothing
    std::map<std::string, std::string> node_sockets;  ///< --node-socket NODE=PATH
    std::optional<std::string> only_node;             ///< --only-node NODE
    double timeout = 30;                              ///< seconds to wait for ports
};

int check_app_file(const std::string& file);
int up(const Common& common, const UpOptions& options);
int down(const Common& common, const std::string& file);

}  // namespace plexus::cli
