#pragma once
// Helpers for starting a peer's server on loopback: a free port, and waiting until it listens.

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "../child_process.hpp"

namespace plexus::bench::peers {

/// A TCP port on 127.0.0.1 that nothing listens on right now (bound to port 0, read, closed).
/// Another process could take it before the server does; start_server retries for that reason.
int free_tcp_port();

/// True once something accepts TCP connections on 127.0.0.1:`port`.
bool accepts_connections(int port);

/// Starts a server with `make_argv(port)` on a free port, logging to `log`, and waits until it
/// accepts connections (up to 10 s). Retries with another port (3 times) if the server exits,
/// e.g. because the port was taken in between. Returns the process; `port` is set.
std::unique_ptr<ChildProcess> start_server(const std::function<std::vector<std::string>(int port)>& make_argv,
                                           const std::string& log, int& port);

/// The full path of a program found in PATH, /usr/sbin or /usr/bin; empty if none.
std::string find_program(const std::string& name);

}  // namespace plexus::bench::peers
