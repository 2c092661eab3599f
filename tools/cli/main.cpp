// plexus: the command-line tool. Parses the command line and hands over to one command.
#include <cstdlib>
#include <iostream>

#include <CLI/CLI.hpp>

#include "apps/app_commands.hpp"
#include "commands.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/defaults.hpp"

int main(int argc, char** argv) {
    using namespace plexus::cli;
    CLI::App app{
        "plexus: connect Plexus ports, read and write them, inspect the live system.\n"
        "Exit status: 0 success, 1 a \"no\" answer, 2 usage error, 3 timeout, 4 refused."};
    app.require_subcommand(1);
    Common common(plexus::proto::default_socket());
    app.add_option("--names", common.names_flag,
                   "name server HOST:PORT (else env PLEXUS_NAMES, the config file's \"names\", multicast "
                   "discovery, 127.0.0.1:10100; see `plexus where`)");
    app.add_option("--socket", common.socket, "local daemon socket (env PLEXUS_SOCKET)")
        ->capture_default_str();
    std::string secret_file;
    app.add_option(
           "--secret-file", secret_file,
           "the deployment secret, to talk to a name server or daemon over TCP (env PLEXUS_SECRET_FILE)")
        ->each([](const std::string& path) { ::setenv("PLEXUS_SECRET_FILE", path.c_str(), 1); });
    int status = 0;

    bool json = false;
    auto* where_cmd = app.add_subcommand(
        "where", "the name server's address and how it was found (flag, env, config, discovery, default)");
    where_cmd->callback([&] { status = where(common); });

    auto* list_cmd = app.add_subcommand("list", "ports (with their node) and connections");
    list_cmd->add_flag("--json", json, "print JSON");
    list_cmd->callback([&] { status = list(common, json); });

    std::string source;
    std::string destination;
    std::string carrier;
    bool persist = false;
    bool strict = false;
    auto* connect_cmd =
        app.add_subcommand("connect", "connect SRC to DST with a carrier (default: local or tcp)");
    connect_cmd->add_option("SRC", source, "source port")->required();
    connect_cmd->add_option("DST", destination, "destination port")->required();
    connect_cmd->add_option("CARRIER", carrier, "carrier string, e.g. tcp or local");
    connect_cmd->add_flag("--persist", persist,
                          "the name server remembers it and restores it when the ports return");
    connect_cmd->add_flag("--strict", strict, "fail instead of warning when arbitration rules overlap");
    connect_cmd->callback([&] { status = connect(common, source, destination, carrier, persist, strict); });

    auto* disconnect_cmd = app.add_subcommand("disconnect", "remove the connection SRC -> DST");
    disconnect_cmd->add_option("SRC", source, "source port")->required();
    disconnect_cmd->add_option("DST", destination, "destination port")->required();
    disconnect_cmd->callback([&] { status = disconnect(common, source, destination); });

    std::string port;
    std::vector<std::string> destinations;
    auto* write_cmd = app.add_subcommand(
        "write", "one message per stdin line (JSON if it parses, else a string); connects PORT -> DST first");
    write_cmd->add_option("PORT", port, "port to open and write from")->required();
    write_cmd->add_option("DST", destinations, "ports to connect to first");
    write_cmd->callback([&] { status = write(common, port, destinations); });

    ReadOptions read_options;
    auto* read_cmd = app.add_subcommand("read", "print each message as one compact JSON line");
    read_cmd->add_option("PORT", read_options.port, "port to open and read")->required();
    read_cmd->add_option("SRC", read_options.source, "connect SRC -> PORT first");
    read_cmd->add_option("CARRIER", read_options.carrier, "carrier for that connection");
    read_cmd->add_option("--count", read_options.count, "exit 0 after N messages")
        ->check(CLI::PositiveNumber);
    read_cmd->add_option("--timeout", read_options.timeout, "exit 3 if not done after SEC seconds")
        ->check(CLI::NonNegativeNumber);
    read_cmd->add_flag("--envelope", read_options.envelope, R"(print {"from","seq","time","data"})");
    read_cmd->add_option("--policy", read_options.policy, "reader queue: strict (no loss) or latest")
        ->check(CLI::IsMember({"strict", "latest"}))
        ->capture_default_str();
    read_cmd->add_option("--queue", read_options.capacity, "reader queue length (default: the daemon's)");
    read_cmd->callback([&] { status = read(common, read_options); });

    auto* exists_cmd =
        app.add_subcommand("exists", "exit 0 if PORT (or the connection SRC DST) exists, else 1");
    exists_cmd->add_option("PORT", port, "port, or source of a connection")->required();
    exists_cmd->add_option("DST", destination, "destination of a connection");
    exists_cmd->callback([&] { status = exists(common, port, destination); });

    double timeout = 0;
    auto* wait_cmd = app.add_subcommand("wait", "wait until PORT is registered");
    wait_cmd->add_option("PORT", port, "port")->required();
    wait_cmd->add_option("--timeout", timeout, "give up (exit 3) after SEC seconds; 0 waits forever")
        ->check(CLI::NonNegativeNumber);
    wait_cmd->callback([&] { status = wait(common, port, timeout); });

    int count = 3;
    auto* ping_cmd = app.add_subcommand("ping", "where PORT lives and how fast its daemon answers");
    ping_cmd->add_option("PORT", port, "port")->required();
    ping_cmd->add_option("--count", count, "round trips to time")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    ping_cmd->callback([&] { status = ping(common, port, count); });

    auto* stats_cmd = app.add_subcommand("stats", "counters of the local daemon, or of PORT's daemon");
    stats_cmd->add_option("PORT", port, "port");
    stats_cmd->add_flag("--json", json, "print JSON");
    stats_cmd->callback([&] { status = stats(common, port, json); });

    EventsOptions events_options;
    auto* events_cmd = app.add_subcommand(
        "events", "the arbitration of an input port: event container, constraints, stimulation, counters");
    events_cmd->add_option("PORT", events_options.port, "input port")->required();
    events_cmd->add_flag("--check", events_options.check,
                         "report pairs of connections whose constraints can both be true (exit 1 if any)");
    events_cmd->add_flag("--watch", events_options.watch, "redraw live until Ctrl-C, like top");
    events_cmd->add_flag("--json", events_options.json, "print JSON (one object per line with --watch)");
    events_cmd->add_option("--interval", events_options.interval, "seconds between redraws with --watch")
        ->check(CLI::Range(0.05, 3600.0))
        ->capture_default_str();
    events_cmd->add_option("--count", events_options.count, "with --watch: stop after N redraws")
        ->check(CLI::PositiveNumber);
    events_cmd->callback([&] { status = events(common, events_options); });

    std::vector<std::string> assignments;
    auto* param_cmd = app.add_subcommand("param", "get or set the parameters of the monitors on SRC -> DST");
    param_cmd->require_subcommand(1);
    auto* param_get = param_cmd->add_subcommand("get", "print getparam() of each monitor, as JSON");
    param_get->add_option("SRC", source, "source port")->required();
    param_get->add_option("DST", destination, "destination port")->required();
    param_get->callback([&] { status = param(common, "get", source, destination, {}); });
    auto* param_set =
        param_cmd->add_subcommand("set", "call setparam({KEY=VALUE...}), then print as get does");
    param_set->add_option("SRC", source, "source port")->required();
    param_set->add_option("DST", destination, "destination port")->required();
    param_set->add_option("KEY=VALUE", assignments, "VALUE is JSON if it parses, else a string")->required();
    param_set->callback([&] { status = param(common, "set", source, destination, assignments); });

    std::string app_file;
    auto* check_cmd = app.add_subcommand(
        "check",
        "validate an application file without touching the system (no daemon needed): its fields, variables, "
        "carriers, scripts, ports named twice, and the arbitration of every port several connections feed "
        "(constraints that can both be true, singular stimulation weights). Exit 0 when fine, 2 with every "
        "problem listed. See docs/APPLICATIONS.md");
    check_cmd->add_option("FILE", app_file, "application file (JSON)")->required();
    check_cmd->callback([&] { status = check_app_file(app_file); });

    UpOptions up_options;
    std::vector<std::string> node_sockets;
    auto* up_cmd = app.add_subcommand(
        "up",
        "bring an application up: check it, start the components that are not running (each in its own "
        "process group, output to a log file beside the daemon's socket, in apps/NAME/), wait for their "
        "ports, "
        "make the connections that are missing and replace those with another carrier. Running it again "
        "changes nothing. Exit 2 for a bad file (nothing changed), 3 when ports do not appear in time, 4 "
        "when "
        "something fails midway (what this up did is undone first)");
    up_cmd->add_option("FILE", up_options.file, "application file (JSON)")->required();
    up_cmd->add_flag("--diff", up_options.diff,
                     "change nothing: print what differs from the live system (components not running, "
                     "connections missing or with another carrier, connections into the file's ports that it "
                     "does not have); exit 0 when nothing, 1 when there is drift");
    up_cmd
        ->add_option("--node-socket", node_sockets,
                     "NODE=PATH: the socket of the daemon of node NODE on this machine, for components "
                     "whose \"node\" is not the local daemon's (repeatable)")
        ->type_size(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    up_cmd->add_option(
        "--only-node", up_options.only_node,
        "start only the components of node NODE (on a machine of a several-machine application) "
        "and make the connections whose ports are all registered");
    up_cmd->add_option("--timeout", up_options.timeout, "seconds to wait for the components' ports")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    up_cmd->callback([&] {
        for (const auto& pair : node_sockets) {
            const auto equals = pair.find('=');
            if (equals == std::string::npos || equals == 0 || equals + 1 == pair.size())
                throw CLI::ValidationError("--node-socket", "expected NODE=PATH, got '" + pair + "'");
            up_options.node_sockets[pair.substr(0, equals)] = pair.substr(equals + 1);
        }
        status = up(common, up_options);
    });

    auto* down_cmd = app.add_subcommand(
        "down",
        "take an application down: remove its connections (those present), then stop the components "
        "`up` started (SIGTERM to each process group, SIGKILL after 5 s) and forget them");
    down_cmd->add_option("FILE", app_file, "application file (JSON)")->required();
    down_cmd->callback([&] { status = down(common, app_file); });

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    } catch (const plexus::Error& e) {
        std::cerr << "plexus: " << e.what() << '\n';
        return static_cast<int>(e.code());
    } catch (const std::exception& e) {
        std::cerr << "plexus: " << e.what() << '\n';
        return 4;
    }
    return status;
}
