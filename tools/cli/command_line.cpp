#include "command_line.hpp"

#include <cstdlib>
#include <iostream>

#include "carrier_help.hpp"
#include "number_checks.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/defaults.hpp"

namespace plexus::cli {

CommandLine::CommandLine()
    : app_(
          "plexus: connect Plexus ports, read and write them, inspect the live system.\n"
          "Exit status: 0 success, 1 a \"no\" answer, 2 usage error, 3 timeout, 4 refused."),
      common_(plexus::proto::default_socket()) {
    app_.require_subcommand(1);
    app_.add_option("--names", common_.names_flag,
                    "name server HOST:PORT (else env PLEXUS_NAMES, the config file's \"names\", multicast "
                    "discovery, 127.0.0.1:10100; see `plexus where`)");
    app_.add_option("--socket", common_.socket, "local daemon socket (env PLEXUS_SOCKET)")
        ->capture_default_str();
    app_.add_option(
            "--secret-file", secret_file_,
            "the deployment secret, to talk to a name server or daemon over TCP (env PLEXUS_SECRET_FILE)")
        ->each([](const std::string& path) { ::setenv("PLEXUS_SECRET_FILE", path.c_str(), 1); });
    app_.add_option("--identity", identity_,
                    "this node's identity directory (made by `plexus pki issue`), when the deployment "
                    "gives its nodes certificates (env PLEXUS_IDENTITY); needs the secret too")
        ->each([](const std::string& path) { ::setenv("PLEXUS_IDENTITY", path.c_str(), 1); });
    add_port_commands();
    add_inspect_commands();
    add_app_commands();
    add_what_if_command();
    add_recording_commands();
    add_call_commands();
    add_pki_commands();
}

// Commands that make connections and move messages.
void CommandLine::add_port_commands() {
    auto* where_cmd = app_.add_subcommand(
        "where", "the name server's address and how it was found (flag, env, config, discovery, default)");
    where_cmd->callback([this] { status_ = where(common_); });

    auto* list_cmd = app_.add_subcommand("list", "ports (with their node) and connections");
    list_cmd->add_flag("--json", json_, "print JSON");
    list_cmd->callback([this] { status_ = list(common_, json_); });

    auto* connect_cmd =
        app_.add_subcommand("connect", "connect SRC to DST with a carrier (default: local or tcp)");
    connect_cmd->add_option("SRC", source_, "source port")->required();
    connect_cmd->add_option("DST", destination_, "destination port")->required();
    connect_cmd->add_option("CARRIER", carrier_, "carrier string, e.g. tcp or local (grammar below)");
    connect_cmd->footer(carrier_help);
    connect_cmd->add_flag("--persist", persist_,
                          "the name server remembers it and restores it when the ports return");
    connect_cmd->add_flag("--strict", strict_, "fail instead of warning when arbitration rules overlap");
    connect_cmd->callback(
        [this] { status_ = connect(common_, source_, destination_, carrier_, persist_, strict_); });

    auto* disconnect_cmd = app_.add_subcommand("disconnect", "remove the connection SRC -> DST");
    disconnect_cmd->add_option("SRC", source_, "source port")->required();
    disconnect_cmd->add_option("DST", destination_, "destination port")->required();
    disconnect_cmd->callback([this] { status_ = disconnect(common_, source_, destination_); });

    auto* write_cmd = app_.add_subcommand(
        "write", "one message per stdin line (JSON if it parses, else a string); connects PORT -> DST first");
    write_cmd->add_option("PORT", port_, "port to open and write from")->required();
    write_cmd->add_option("DST", destinations_, "ports to connect to first");
    write_cmd->callback([this] { status_ = write(common_, port_, destinations_); });

    auto& read_options = read_options_;
    auto* read_cmd = app_.add_subcommand("read", "print each message as one compact JSON line");
    read_cmd->add_option("PORT", read_options.port, "port to open and read")->required();
    read_cmd->add_option("SRC", read_options.source, "connect SRC -> PORT first");
    read_cmd->add_option("CARRIER", read_options.carrier, "carrier for that connection");
    read_cmd->add_option("--count", read_options.count, "exit 0 after N messages (default: no limit)")
        ->transform(whole_number(1, most_count));
    read_cmd
        ->add_option("--timeout", read_options.timeout,
                     "exit 3 if not done after SEC seconds (default: no limit)")
        ->transform(seconds(0.001, most_seconds));
    read_cmd->add_flag("--envelope", read_options.envelope, R"(print {"from","seq","time","data"})");
    read_cmd->add_option("--policy", read_options.policy, "reader queue: strict (no loss) or latest")
        ->check(CLI::IsMember({"strict", "latest"}))
        ->capture_default_str();
    // No 0 for "the daemon's default": leaving --queue out says that, and a 0 that silently meant
    // 1024 surprised (issue 26).
    read_cmd
        ->add_option("--queue", read_options.capacity,
                     "reader queue length in messages (default: the daemon's default_capacity, 1024 unless "
                     "its config says otherwise)")
        ->transform(whole_number(1, most_count));
    read_cmd->callback([this] { status_ = read(common_, read_options_); });

    auto* exists_cmd =
        app_.add_subcommand("exists", "exit 0 if PORT (or the connection SRC DST) exists, else 1");
    exists_cmd->add_option("PORT", port_, "port, or source of a connection")->required();
    exists_cmd->add_option("DST", destination_, "destination of a connection");
    exists_cmd->callback([this] { status_ = exists(common_, port_, destination_); });

    auto* wait_cmd = app_.add_subcommand("wait", "wait until PORT is registered");
    wait_cmd->add_option("PORT", port_, "port")->required();
    wait_cmd->add_option("--timeout", wait_timeout_, "give up (exit 3) after SEC seconds; 0 waits forever")
        ->transform(seconds(0, most_seconds));
    wait_cmd->callback([this] { status_ = wait(common_, port_, wait_timeout_); });
}

// Commands that look at the live system and talk to its monitors.
void CommandLine::add_inspect_commands() {
    auto* ping_cmd = app_.add_subcommand("ping", "where PORT lives and how fast its daemon answers");
    ping_cmd->add_option("PORT", port_, "port")->required();
    // Each round trip's time is kept to find the median: a million of them is 8 MB.
    ping_cmd->add_option("--count", ping_count_, "round trips to time")
        ->transform(whole_number(1, 1'000'000))
        ->capture_default_str();
    ping_cmd->callback([this] { status_ = ping(common_, port_, ping_count_); });

    auto* stats_cmd = app_.add_subcommand("stats", "counters of the local daemon, or of PORT's daemon");
    stats_cmd->add_option("PORT", port_, "port");
    stats_cmd->add_flag("--json", json_, "print JSON");
    stats_cmd->callback([this] { status_ = stats(common_, port_, json_); });

    auto* web_cmd = app_.add_subcommand(
        "web",
        "print the address of the local daemon's web page (plexusd --http): the graph of the "
        "whole system and arbitration, live; opens nothing by itself");
    web_cmd->add_flag("--token", web_token_,
                      "print instead the web token a browser beyond loopback enters once (needs the "
                      "deployment secret: --secret-file or PLEXUS_SECRET_FILE)");
    web_cmd->callback([this] { status_ = web(common_, web_token_); });

    auto& events_options = events_options_;
    auto* events_cmd = app_.add_subcommand(
        "events", "the arbitration of an input port: event container, constraints, stimulation, counters");
    events_cmd->add_option("PORT", events_options.port, "input port")->required();
    events_cmd->add_flag("--check", events_options.check,
                         "report pairs of connections whose constraints can both be true (exit 1 if any)");
    events_cmd->add_flag("--watch", events_options.watch, "redraw live until Ctrl-C, like top");
    events_cmd->add_flag("--json", events_options.json, "print JSON (one object per line with --watch)");
    events_cmd->add_option("--interval", events_options.interval, "seconds between redraws with --watch")
        ->transform(seconds(0.05, 3600))
        ->capture_default_str();
    events_cmd->add_option("--count", events_options.count, "with --watch: stop after N redraws")
        ->transform(whole_number(1, most_count));
    events_cmd->callback([this] { status_ = events(common_, events_options_); });

    auto* param_cmd = app_.add_subcommand("param", "get or set the parameters of the monitors on SRC -> DST");
    param_cmd->require_subcommand(1);
    auto* param_get = param_cmd->add_subcommand("get", "print getparam() of each monitor, as JSON");
    param_get->add_option("SRC", source_, "source port")->required();
    param_get->add_option("DST", destination_, "destination port")->required();
    param_get->callback([this] { status_ = param(common_, "get", source_, destination_, {}); });
    auto* param_set =
        param_cmd->add_subcommand("set", "call setparam({KEY=VALUE...}), then print as get does");
    param_set->add_option("SRC", source_, "source port")->required();
    param_set->add_option("DST", destination_, "destination port")->required();
    param_set->add_option("KEY=VALUE", assignments_, "VALUE is JSON if it parses, else a string")->required();
    param_set->callback([this] { status_ = param(common_, "set", source_, destination_, assignments_); });
}

// `plexus what-if`: a recording re-run offline (no daemon needed).
void CommandLine::add_what_if_command() {
    auto& args = what_if_args_;
    auto* cmd = app_.add_subcommand("what-if",
                                    "re-run a recorded port's arbitration and recv-side monitors offline, "
                                    "with the daemon's own code, and "
                                    "print the decisions that come out otherwise (no daemon needed)");
    cmd->add_option("FILE", args.file, "a recording (plexus record ... -o FILE.mcap)")->required();
    cmd->add_option("PORT", args.port, "the recorded input port to re-run")->required();
    cmd->add_option(
        "--carrier", args.carriers,
        "SOURCE=CARRIER: re-run the connection from SOURCE with this full carrier text instead of "
        "the recorded one (weights, constraints, scripts), e.g. "
        "/obj/out=local+recv.priority+tc.0.5+ex./face/out:0 (repeatable)");
    cmd->add_flag(
        "--json", args.json,
        "one JSON object per line for each message decided otherwise: {\"source\", \"seq\", \"time\", "
        "\"recorded\", \"what_if\"}; then a last line {\"messages\": N, \"changed\": K}");
    cmd->add_option("--svg", args.svg,
                    "also draw the recorded and what-if decisions as an SVG timeline into this file");
    cmd->add_option("--scripts", args.script_dirs,
                    "directory of the monitor scripts the carriers name (file.NAME), as plexusd --scripts "
                    "(repeatable)");
    cmd->add_option("--monitor-libs", args.monitor_lib_dirs,
                    "directory of compiled monitors (type.so), as plexusd --monitor-libs (repeatable)");
    cmd->footer(
        "Each recorded message is re-run in two steps at its recorded times, on a clock that "
        "PortMonitor.now()\n"
        "and event lifetimes read: its monitors at the instant they began, its arbitration at the instant\n"
        "the daemon decided; all connections' steps in time order. With the recorded carriers the decisions\n"
        "come out as recorded (0 changed).\n"
        "Not compared, and counted: messages the recording holds no decision for (in flight at its end),\n"
        "and those decided while stimulation from before the recording could still count (the warm-up).\n"
        "Text output: a line per changed message (seconds from the start, source, seq, recorded -> "
        "what-if),\n"
        "then messages compared and changed, per source the deliveries recorded -> what-if, and how often\n"
        "the delivering source switched. Exit 0 whatever the count; 2 bad arguments (a port not in the\n"
        "recording, a --carrier that does not parse or load); 4 a file that is not a readable recording\n"
        "(the reader names the byte offset).");
    cmd->callback([this] { status_ = what_if(what_if_args_); });
}

// Recordings: record, play (docs/RECORDING.md).
void CommandLine::add_recording_commands() {
    auto& record = record_options_;
    auto* record_cmd = app_.add_subcommand(
        "record",
        "record ports of the local daemon into an MCAP file: every message that reaches them, what "
        "their monitors and arbitration decided, their events (docs/RECORDING.md). The daemon "
        "writes the file; runs until Ctrl-C, --duration or --max-bytes");
    record_cmd->add_option("PORT", record.ports, "ports of the local daemon to record");
    record_cmd->add_option(
        "-o,--output", record.output,
        "the file to write, never overwritten (default: plexus-YYYYmmdd-HHMMSS.mcap here)");
    record_cmd->add_flag("--all", record.all, "record every port of the local daemon");
    record_cmd->add_option("--duration", record.duration, "stop after this many seconds")
        ->transform(seconds(0.001, 31'536'000));
    record_cmd
        ->add_option("--max-bytes", record.max_bytes,
                     "stop once the files hold this many bytes (any number of bytes)")
        ->transform(whole_number(1, UINT64_MAX));
    record_cmd
        ->add_option(
            "--split-bytes", record.split_bytes,
            "start a new file (FILE-STEM.1.mcap, .2, ...) past this many bytes (any number of bytes)")
        ->transform(whole_number(1, UINT64_MAX));
    record_cmd->add_option("--info", record.info, "print what the recording FILE holds instead");
    record_cmd->add_flag("--json", record.json, "print JSON");
    record_cmd->callback([this] { status_ = plexus::cli::record(common_, record_options_); });

    auto& play = play_options_;
    auto* play_cmd = app_.add_subcommand(
        "play",
        "write the recorded sources' messages again, with their recorded timing, from ports of their "
        "names on the local daemon: the connections that exist now carry them (stop the original "
        "components first, or --remap)");
    play_cmd->add_option("FILE", play.file, "a recording made by plexus record")->required();
    play_cmd->add_option("--rate", play.rate, "speed: 2 plays twice as fast")
        ->transform(seconds(0.001, 1000));
    play_cmd->add_flag("--loop", play.loop, "start again at the end, until Ctrl-C");
    play_cmd->add_option("--remap", play.remaps, "play source OLD from port NEW (OLD=NEW, repeatable)");
    play_cmd->add_option("--start", play.start, "skip the first S seconds (0: from the start)")
        ->transform(seconds(0, 31'536'000));
    play_cmd->add_option("--end", play.end, "stop S seconds after the recording's start")
        ->transform(seconds(0.001, 31'536'000));
    play_cmd->add_option("--ports", play.ports, "play only the sources of these recorded ports");
    play_cmd
        ->add_option(
            "--wait", play.wait,
            "seconds to wait for connections out of the opened ports before playing (0: do not wait)")
        ->transform(seconds(0, 3600))
        ->capture_default_str();
    play_cmd->callback([this] { status_ = plexus::cli::play(common_, play_options_); });
}

// Request/reply (docs/CALLS.md).
void CommandLine::add_call_commands() {
    auto& call = call_options_;
    auto* call_cmd = app_.add_subcommand(
        "call",
        "call the service at PORT with VALUE and print its answer as one JSON line (exit 3: no answer in "
        "time; 4: refused or failed, with the reason)");
    call_cmd->add_option("PORT", call.port, "a served port, or a port whose connections lead to servers")
        ->required();
    call_cmd->add_option("VALUE", call.value, "the request: JSON if it parses, else a string")->required();
    call_cmd->add_option("--timeout", call.timeout, "seconds to wait for the answer")
        ->transform(seconds(0.001, 86'400))
        ->capture_default_str();
    call_cmd->callback([this] { status_ = plexus::cli::call(common_, call_options_); });

    auto& serve = serve_options_;
    auto* serve_cmd =
        app_.add_subcommand("serve", "open PORT to serve it and answer each call, until Ctrl-C (or SIGTERM)");
    serve_cmd->add_option("PORT", serve.port, "the port to open and serve")->required();
    serve_cmd->add_flag("--echo", serve.echo, "answer each request with the request itself");
    serve_cmd->add_option("--exec", serve.exec,
                          "answer with the standard output of this shell command, given the request as one "
                          "JSON line on its standard input (JSON if the output parses, else a string); a "
                          "command that fails fails the call with its standard error");
    serve_cmd->callback([this] { status_ = plexus::cli::serve(common_, serve_options_); });
}

// Commands on application files (docs/APPLICATIONS.md).
void CommandLine::add_app_commands() {
    auto* check_cmd = app_.add_subcommand(
        "check",
        "validate an application file without touching the system (no daemon needed): its fields, variables, "
        "carriers, scripts, ports named twice, and the arbitration of every port several connections feed "
        "(constraints that can both be true, singular stimulation weights). Exit 0 when fine, 2 with every "
        "problem listed. See docs/APPLICATIONS.md");
    check_cmd->add_option("FILE", app_file_, "application file (JSON)")->required();
    check_cmd->callback([this] { status_ = check_app_file(app_file_); });

    auto* up_cmd = app_.add_subcommand(
        "up",
        "bring an application up: check it, start the components that are not running (each in its own "
        "process group, output to a log file beside the daemon's socket, in apps/NAME/), wait for their "
        "ports, "
        "make the connections that are missing and replace those with another carrier. Running it again "
        "changes nothing. Exit 2 for a bad file (nothing changed), 3 when ports do not appear in time, 4 "
        "when "
        "something fails midway (what this up did is undone first)");
    up_cmd->add_option("FILE", up_options_.file, "application file (JSON)")->required();
    up_cmd->add_flag("--diff", up_options_.diff,
                     "change nothing: print what differs from the live system (components not running, "
                     "connections missing or with another carrier, connections into the file's ports that it "
                     "does not have); exit 0 when nothing, 1 when there is drift");
    up_cmd
        ->add_option("--node-socket", node_sockets_,
                     "NODE=PATH: the socket of the daemon of node NODE on this machine, for components "
                     "whose \"node\" is not the local daemon's (repeatable)")
        ->type_size(1)
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    up_cmd->add_option(
        "--only-node", up_options_.only_node,
        "start only the components of node NODE (on a machine of a several-machine application) "
        "and make the connections whose ports are all registered");
    up_cmd->add_option("--timeout", up_options_.timeout, "seconds to wait for the components' ports")
        ->transform(seconds(0.001, most_seconds))
        ->capture_default_str();
    up_cmd->callback([this] {
        for (const auto& pair : node_sockets_) {
            const auto equals = pair.find('=');
            if (equals == std::string::npos || equals == 0 || equals + 1 == pair.size())
                throw CLI::ValidationError("--node-socket", "expected NODE=PATH, got '" + pair + "'");
            up_options_.node_sockets[pair.substr(0, equals)] = pair.substr(equals + 1);
        }
        status_ = up(common_, up_options_);
    });

    auto* down_cmd = app_.add_subcommand(
        "down",
        "take an application down: remove its connections (those present), then stop the components "
        "`up` started (SIGTERM to each process group, SIGKILL after 5 s) and forget them");
    down_cmd->add_option("FILE", app_file_, "application file (JSON)")->required();
    down_cmd->callback([this] { status_ = down(common_, app_file_); });
}

namespace {

/// "plexus param" for the `param` subcommand: the words a user typed to reach `app`.
std::string command_path(const CLI::App& app) {
    return app.get_parent() ? command_path(*app.get_parent()) + " " + app.get_name() : "plexus";
}

/// When the command word is missing or unknown, what to say instead of CLI11's "A subcommand is
/// required": which word was not a command, and the commands there are. Empty otherwise.
std::string missing_command(const CLI::App& root) {
    const CLI::App* chosen = &root;
    while (!chosen->get_subcommands().empty())
        chosen = chosen->get_subcommands().front();
    if (chosen->get_require_subcommand_min() == 0 || chosen->get_subcommands().size() > 0)
        return {};
    std::string names;
    for (const CLI::App* sub : chosen->get_subcommands([](const CLI::App*) { return true; }))
        names += (names.empty() ? "" : ", ") + sub->get_name();
    const auto unknown = root.remaining(true);
    const std::string what =
        unknown.empty() ? "a command is required" : "unknown command '" + unknown.front() + "'";
    return command_path(*chosen) + ": " + what + "; the commands are: " + names + " (see " +
           command_path(*chosen) + " --help)";
}

}  // namespace

int CommandLine::run(int argc, char** argv) {
    try {
        app_.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // Only in place of CLI11's RequiredError: --help is a ParseError too.
        const bool required = dynamic_cast<const CLI::RequiredError*>(&e) != nullptr;
        if (const std::string message = required ? missing_command(app_) : ""; !message.empty()) {
            std::cerr << message << '\n';
            return 2;
        }
        const int code = app_.exit(e);
        return code == 0 ? 0 : 2;
    } catch (const plexus::Error& e) {
        std::cerr << "plexus: " << e.what() << '\n';
        return static_cast<int>(e.code());
    } catch (const std::exception& e) {
        std::cerr << "plexus: " << e.what() << '\n';
        return 4;
    }
    return status_;
}

}  // namespace plexus::cli
