#pragma once
// The processes one system needs for a hop count, started on loopback and stopped on destruction:
// Plexus (one plexusd, or two linked by tcp) or the floor (one relay, or two linked by tcp).

#include <sys/types.h>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "child_process.hpp"

namespace plexus::bench {

/// Starts a process (kept in `processes`) and waits until its ready file parses as JSON; returns
/// that JSON text. Throws naming `what` (and the process's last log lines) if it never does.
std::string start_when_ready(std::vector<std::unique_ptr<ChildProcess>>& processes,
                             const std::vector<std::string>& argv, const std::string& ready_file,
                             const std::string& log, const std::string& what);

class Topology {
public:
    /// One plexusd with its embedded name server; with hops == 2 a second one that uses it.
    /// `extra` goes to every plexusd (e.g. --scripts DIR).
    static std::unique_ptr<Topology> plexus(const TempDir& dir, const std::string& plexusd, int hops,
                                            const std::vector<std::string>& extra = {});
    /// One relay (this program's hidden `relay` command); with hops == 2 two, linked by tcp.
    static std::unique_ptr<Topology> floor(const TempDir& dir, int hops);
    /// Daemons started by someone else (on the hosts of `plexus-bench hosts`), which outlive it:
    /// their Unix sockets, first (near) to last (far), and their pids.
    static std::unique_ptr<Topology> existing(std::vector<std::string> sockets, std::vector<pid_t> pids);

    /// The socket of the first hop: where the writing (or pinging) client connects.
    const std::string& near_socket() const { return sockets_.front(); }
    /// The socket of the last hop: where the reading (or echoing) client connects.
    const std::string& far_socket() const { return sockets_.back(); }
    /// The broker processes (daemons or relays), whose CPU time is the cost being measured.
    std::vector<pid_t> pids() const;
    /// The ready file (JSON text) of the hop-th process started, first (near) to last (far).
    const std::string& ready(std::size_t hop) const { return readies_.at(hop); }

private:
    Topology() = default;
    /// Starts a process and waits until its ready file parses as JSON; returns that JSON text.
    std::string start(const std::vector<std::string>& argv, const std::string& ready_file,
                      const std::string& log);

    std::vector<std::unique_ptr<ChildProcess>> processes_;
    std::vector<pid_t> existing_pids_;  ///< processes of existing(), not stopped here
    std::vector<std::string> sockets_;
    std::vector<std::string> readies_;  ///< ready files of the processes started, in order
};

}  // namespace plexus::bench
