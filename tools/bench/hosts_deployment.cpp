#include "hosts_deployment.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "pki.hpp"
#include "run_deadline.hpp"

namespace plexus::bench {

namespace {

/// `command` with `extra` appended.
std::vector<std::string> with(const std::vector<std::string>& extra, std::vector<std::string> command) {
    command.insert(command.end(), extra.begin(), extra.end());
    return command;
}

}  // namespace

std::string start_ready(std::vector<std::unique_ptr<ChildProcess>>& processes,
                        const std::vector<std::string>& argv, const std::string& ready_file,
                        const std::string& log) {
    return start_when_ready(processes, argv, ready_file, log, argv.at(4) + " on " + argv.at(3));
}

Deployment::Deployment(const HostsNetwork& network, const TempDir& dir, const HostsOptions& options,
                       const std::string& tag, const std::string& secret_file, const std::vector<int>& hosts,
                       int names_port, const std::string& mcast_range, int mcast_port, bool identities) {
    std::vector<std::string> trust = secret_file.empty()
                                         ? std::vector<std::string>{"--insecure"}
                                         : std::vector<std::string>{"--secret-file", secret_file};
    const std::string ca = dir.file(tag + "-ca");
    const auto identity = [&](const proto::Subject& subject) -> std::vector<std::string> {
        if (!identities)
            return {};
        auto issued = cli::pki_issue(ca, subject, "", 3650);
        if (!issued)
            throw std::runtime_error("cannot issue " + subject.text() + ": " + issued.error().message);
        return {"--identity", *issued};
    };
    std::vector<std::string> permissions;
    if (identities) {
        if (auto made = cli::pki_init(ca, 3650); !made)
            throw std::runtime_error("cannot make the bench's CA: " + made.error().message);
        // The bench's nodes may do what it does; a rule per action and one for its local user, so a
        // check walks the rules as a real file's would.
        const std::string file = dir.file(tag + "-permissions.json");
        std::ofstream(file) << nlohmann::json{
            {"rules",
             {{{"nodes", {"someone-else"}}, {"allow", {"open", "write"}}, {"ports", {"/elsewhere/**"}}},
              {{"nodes", {tag + "-h*"}}, {"allow", {"open", "read", "write", "connect"}}, {"ports", {"/**"}}},
              {{"users", {::getuid()}},
               {"allow", {"open", "read", "write", "connect", "monitor"}},
               {"ports", {"/**"}}}}}};
        permissions = {"--permissions", file};
    }
    const std::string names_ready = dir.file(tag + "-names.ready");
    std::vector<std::string> names_argv{options.plexus_names,
                                        "--listen",
                                        network.address(0) + ":" + std::to_string(names_port),
                                        "--ready-file",
                                        names_ready,
                                        "--discovery",
                                        "off",
                                        "--mcast-range",
                                        mcast_range,
                                        "--mcast-port",
                                        std::to_string(mcast_port),
                                        "--log-level",
                                        "warn"};
    names_argv.insert(names_argv.end(), trust.begin(), trust.end());
    const auto names_identity = identity({proto::Subject::Kind::names, tag + "-names"});
    names_argv.insert(names_argv.end(), names_identity.begin(), names_identity.end());
    names_ =
        nlohmann::json::parse(start(network.wrap(0, names_argv), names_ready, dir.file(tag + "-names.log")))
            .at("names")
            .get<std::string>();
    for (const int k : hosts) {
        const std::string node = tag + "-h" + std::to_string(k);
        const std::string socket = dir.file(node + ".sock");
        const std::string ready_file = dir.file(node + ".ready");
        std::vector<std::string> argv{options.plexusd, "--listen", network.address(k) + ":0",
                                      "--names",       names_,     "--socket",
                                      socket,          "--node",   node,
                                      "--ready-file",  ready_file, "--log-level",
                                      "warn"};
        argv.insert(argv.end(), trust.begin(), trust.end());
        const auto node_identity = identity({proto::Subject::Kind::node, node});
        argv.insert(argv.end(), node_identity.begin(), node_identity.end());
        argv.insert(argv.end(), permissions.begin(), permissions.end());
        const auto ready =
            nlohmann::json::parse(start(network.wrap(k, argv), ready_file, dir.file(node + ".log")));
        sockets_[k] = ready.value("socket", socket);
        pids_[k] = processes_.back()->pid();
    }
}

RelayPair::RelayPair(const HostsNetwork& network, const TempDir& dir, const std::string& tag, int a, int b,
                     bool udp) {
    std::vector<std::string> link_mode;
    if (udp)
        link_mode.push_back("--udp-link");
    const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
    const std::string near_socket = dir.file(tag + "-relay-a.sock");
    const std::string far_socket = dir.file(tag + "-relay-b.sock");
    const std::string near_ready = dir.file(tag + "-relay-a.ready");
    const std::string far_ready = dir.file(tag + "-relay-b.ready");
    const auto near = nlohmann::json::parse(start_ready(
        processes_,
        network.wrap(a, with(link_mode, {self, "relay", "--socket", near_socket, "--ready-file", near_ready,
                                         "--link-listen", "--link-address", network.address(a)})),
        near_ready, dir.file(tag + "-relay-a.log")));
    start_ready(
        processes_,
        network.wrap(b, with(link_mode, {self, "relay", "--socket", far_socket, "--ready-file", far_ready,
                                         "--link-connect", near.at("link").get<std::string>()})),
        far_ready, dir.file(tag + "-relay-b.log"));
    topology_ = Topology::existing({near_socket, far_socket}, {processes_[0]->pid(), processes_[1]->pid()});
}

std::string write_secret(const TempDir& dir) {
    const std::string path = dir.file("secret");
    std::string secret;
    std::ifstream random("/dev/urandom", std::ios::binary);
    for (int i = 0; i < 32; ++i)
        secret += "0123456789abcdef"[static_cast<unsigned char>(random.get()) % 16];
    {
        std::ofstream out(path, std::ios::trunc);
        out << secret << '\n';
    }
    ::chmod(path.c_str(), 0600);  // plexusd refuses a secret others may read
    return path;
}

Row alternate(Row row, const std::vector<std::pair<std::string, Measurement*>>& systems, int repeat) {
    std::vector<std::vector<RunResult>> runs(systems.size());
    for (int round = 0; round < repeat; ++round) {
        for (std::size_t j = 0; j < systems.size(); ++j) {
            const std::size_t i = (j + static_cast<std::size_t>(round)) % systems.size();
            RunDeadline deadline;
            runs[i].push_back(systems[i].second->run());
        }
    }
    for (std::size_t i = 0; i < systems.size(); ++i)
        row.systems.emplace_back(systems[i].first, median_of(runs[i]));
    return row;
}

Options options_for(std::size_t size, std::size_t count, const std::string& carrier) {
    Options options;
    options.size = size;
    options.count = count;
    options.carrier = carrier;
    return options;
}

}  // namespace plexus::bench
