#pragma once
// Pure functions: which address of a daemon the name server records and gives out.

#include <optional>
#include <string>

#include "../net/asio.hpp"

namespace plexus::daemon::names {

/// The two ends of a TCP session with the name server; both empty for a UDP datagram.
struct SessionAddresses {
    std::optional<asio::ip::address> remote;  ///< where the asker is
    std::optional<asio::ip::address> local;   ///< the name server's address the asker reached
};

/// The address to record for a daemon that announced `announced` ("HOST:PORT"). A daemon that
/// listens on every interface (0.0.0.0 or ::) announces a host nobody can connect to: the name
/// server records the address the daemon's session came from instead (plexusd --advertise HOST
/// overrides both).
std::string recorded_address(const std::string& announced, const SessionAddresses& daemon);

/// The address to give `asker` for a daemon recorded at `recorded`. A daemon on the name server's
/// own machine may be recorded at loopback (its session came over loopback); to an asker on another
/// machine it is at the address that asker used to reach the name server.
std::string address_for(const std::string& recorded, const SessionAddresses& asker);

}  // namespace plexus::daemon::names
