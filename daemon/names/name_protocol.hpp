#pragma once
// The records the name server's operations carry: one header for the server that answers them and
// the daemon's client that asks.

#include <string>

#include "plexus/proto/ops.hpp"

namespace plexus::daemon::names {

// The ops themselves are proto::Op (plexus/proto/ops.hpp), with the daemon's; their requests and
// replies are the structs of plexus/proto/name_operations.hpp.

struct PortEntry {
    std::string name;
    std::string node;
    std::string address;  ///< the node daemon's TCP address, HOST:PORT
};

struct ConnectionEntry {
    std::string source;
    std::string destination;
    std::string carrier;
    bool persistent = false;
};

}  // namespace plexus::daemon::names
