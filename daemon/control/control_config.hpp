#pragma once
// The part of the daemon's settings that the control plane (and the inspect and web views above
// it) reads: the node's name, its name server, the queue a client gets when it does not say, and
// net/'s part below. The daemon's whole configuration (app/daemon_config.hpp) extends it.

#include <cstddef>
#include <memory>
#include <string>

#include "core/permissions.hpp"
#include "net/net_config.hpp"
#include "plexus/proto/endpoint.hpp"

namespace plexus::daemon {

struct ControlConfig : NetConfig {
    std::string node;
    proto::Endpoint names{"127.0.0.1", 10100};
    std::size_t default_capacity = 1024;  ///< reader queue length when a client does not say
    /// --permissions: who may open, write, read, connect or attach monitors to which ports; null:
    /// everyone may do everything (core/permissions.hpp).
    std::shared_ptr<const Permissions> permissions;
};

}  // namespace plexus::daemon
