#include "topology.hpp"

#include <unistd.h>

#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace plexus::bench {

using namespace std::chrono_literals;

namespace {

std::string own_executable() {
    std::error_code error;
    auto path = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error)
        throw std::runtime_error("cannot find this program's path: " + error.message());
    return path.string();
}

}  // namespace

std::string start_when_ready(std::vector<std::unique_ptr<ChildProcess>>& processes,
                             const std::vector<std::string>& argv, const std::string& ready_file,
                             const std::string& log, const std::string& what) {
    processes.push_back(std::make_unique<ChildProcess>(argv, log));
    auto& process = *processes.back();
    std::string ready;
    const bool started = poll_until(
        [&] {
            if (!std::filesystem::exists(ready_file))
                return !process.running();
            ready = read_file(ready_file);
            return nlohmann::json::accept(ready);
        },
        20s);
    if (!started || ready.empty())
        throw std::runtime_error(what + " did not become ready (" + ready_file + "):\n" + process.log_tail());
    return ready;
}

std::string Topology::start(const std::vector<std::string>& argv, const std::string& ready_file,
                            const std::string& log) {
    readies_.push_back(start_when_ready(processes_, argv, ready_file, log, argv.front()));
    return readies_.back();
}

std::unique_ptr<Topology> Topology::plexus(const TempDir& dir, const std::string& plexusd, int hops,
                                           const std::vector<std::string>& extra) {
    std::unique_ptr<Topology> topology(new Topology);
    std::string names;
    for (int hop = 0; hop < hops; ++hop) {
        const std::string node = hop == 0 ? "a" : "b";
        const std::string socket = dir.file("plexusd-" + node + ".sock");
        const std::string ready_file = dir.file("plexusd-" + node + ".ready");
        std::vector<std::string> argv{plexusd, "--listen",     "127.0.0.1:0", "--socket",    socket, "--node",
                                      node,    "--ready-file", ready_file,    "--log-level", "warn"};
        if (hop == 0) {
            argv.insert(argv.end(), {"--embedded-names", "--names", "127.0.0.1:0"});
        } else {
            argv.insert(argv.end(), {"--names", names});
        }
        argv.insert(argv.end(), extra.begin(), extra.end());
        const auto ready =
            nlohmann::json::parse(topology->start(argv, ready_file, dir.file("plexusd-" + node + ".log")));
        if (hop == 0)
            names = ready.at("names").get<std::string>();
        topology->sockets_.push_back(ready.value("socket", socket));
    }
    return topology;
}

std::unique_ptr<Topology> Topology::floor(const TempDir& dir, int hops) {
    std::unique_ptr<Topology> topology(new Topology);
    const std::string self = own_executable();
    std::string link;
    for (int hop = 0; hop < hops; ++hop) {
        const std::string node = hop == 0 ? "a" : "b";
        const std::string socket = dir.file("relay-" + node + ".sock");
        const std::string ready_file = dir.file("relay-" + node + ".ready");
        std::vector<std::string> argv{self, "relay", "--socket", socket, "--ready-file", ready_file};
        if (hops == 2 && hop == 0)
            argv.emplace_back("--link-listen");
        if (hop == 1)
            argv.insert(argv.end(), {"--link-connect", link});
        const auto ready =
            nlohmann::json::parse(topology->start(argv, ready_file, dir.file("relay-" + node + ".log")));
        if (hop == 0 && hops == 2)
            link = ready.at("link").get<std::string>();
        topology->sockets_.push_back(socket);
    }
    return topology;
}

std::unique_ptr<Topology> Topology::existing(std::vector<std::string> sockets, std::vector<pid_t> pids) {
    if (sockets.empty())
        throw std::runtime_error("a topology needs at least one socket");
    std::unique_ptr<Topology> topology(new Topology);
    topology->sockets_ = std::move(sockets);
    topology->existing_pids_ = std::move(pids);
    return topology;
}

std::vector<pid_t> Topology::pids() const {
    std::vector<pid_t> pids = existing_pids_;
    for (const auto& process : processes_)
        pids.push_back(process->pid());
    return pids;
}

}  // namespace plexus::bench
