// plexus-bench: latency, throughput and memory of Plexus, each measured against a minimal relay
// (the "floor") in the same run. Parses the command line and hands over to one scenario.
#include <csignal>
#include <iostream>

#include <CLI/CLI.hpp>

#include "bridges/bridges_scenario.hpp"
#include "bridges/ends.hpp"
#include "hosts_scenario.hpp"
#include "options.hpp"
#include "peers/own_process_run.hpp"
#include "peers/peers_command.hpp"
#include "plexus/client.hpp"
#include "relay.hpp"
#include "scenarios.hpp"
#ifdef PLEXUS_BENCH_PEERS
#include "peers/peer_systems.hpp"
#endif

int main(int argc, char** argv) {
    using namespace plexus::bench;
    CLI::App app{
        "plexus-bench: measures Plexus on loopback and, in the same run, a minimal Unix-socket relay "
        "carrying the same traffic (the floor). See docs/BENCHMARKS.md."};
    app.require_subcommand(1);
    Options options;
    options.plexusd = PLEXUSD_PATH;
    int status = 0;

    auto add_common = [&](CLI::App* command) {
        command
            ->add_option("--size", options.size,
                         "payload bytes per message (plexusd's frame limit is 64 MiB)")
            ->check(CLI::Range(std::size_t{0}, std::size_t{32} << 20))
            ->capture_default_str();
        command->add_option("--hops", options.hops, "1: one daemon; 2: two daemons linked by tcp")
            ->check(CLI::IsMember({1, 2}))
            ->capture_default_str();
        command->add_option("--count", options.count, "round trips or messages per run (default: by size)")
            ->check(CLI::PositiveNumber);
        command->add_option("--repeat", options.repeat, "runs per system; medians are reported")
            ->check(CLI::PositiveNumber)
            ->capture_default_str();
        command
            ->add_option("--capacity", options.capacity,
                         "reader queue length asked of plexusd (0: its default)")
            ->capture_default_str();
        command->add_flag("--json", options.json, "one JSON object per line and system");
        command->add_option("--plexusd", options.plexusd, "the plexusd binary")->capture_default_str();
    };
    auto* latency = app.add_subcommand("latency", "ping-pong: p50/p99 of round trip / 2");
    add_common(latency);
    latency->add_flag("--loans", options.loans,
                      "Plexus writes zero-copy loans and reads in-place views (the payload is not "
                      "touched past its first 64 bytes); the floor still copies");
    latency->callback([&] { status = run_latency(options); });
    auto* calls = app.add_subcommand(
        "calls",
        "request/reply: p50/p99/mean call round trip, a served port answering with the request, one "
        "call at a time; the floor is the ping-pong through the same hops");
    add_common(calls);
    calls->callback([&] { status = run_calls(options); });
    auto* throughput =
        app.add_subcommand("throughput", "one writer streams, one reader reads all (strict queue)");
    add_common(throughput);
    throughput->callback([&] { status = run_throughput(options); });
    auto* monitor = app.add_subcommand(
        "monitor",
        "throughput and daemon CPU without a monitor, with a one-field accept, with a rewriting update");
    add_common(monitor);
    monitor->add_flag("--empty-accept", options.empty_accept,
                      "also run `accept_empty`: an accept that returns true without touching msg, "
                      "the cost of calling a script at all");
    monitor->callback([&] { status = run_monitor(options); });
    auto* monitor_latency = app.add_subcommand(
        "monitor-latency",
        "one-hop p50/p99 without a monitor and with a recv monitor (which runs on a worker)");
    add_common(monitor_latency);
    monitor_latency->callback([&] { status = run_monitor_latency(options); });
    auto* scaling = app.add_subcommand(
        "monitor-scaling", "total throughput of 1, 2, 4 independent connections with a ~20 us monitor each");
    add_common(scaling);
    scaling->callback([&] { status = run_monitor_scaling(options); });
    auto* streams = app.add_subcommand(
        "streams", "deliveries/s and CPU per message of 1, 10, 100, 1,000 independent 64 B streams");
    add_common(streams);
    streams->add_option("--streams", options.streams, "the rows: streams per run")
        ->delimiter(',')
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    streams
        ->add_option("--clients", options.stream_clients,
                     "writer clients (and as many reader clients) the streams are spread over")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    streams
        ->add_option(
            "--daemon-threads", options.daemon_threads,
            "plexusd --threads for each set of rows, e.g. 1,2: one daemon each, their runs alternating")
        ->delimiter(',')
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    streams->callback([&] { status = run_streams(options); });

    auto* arbitration = app.add_subcommand("arbitration",
                                           "added CPU per message with 2, 4, 8 competing connections "
                                           "(constraints, priority) and the switch time");
    add_common(arbitration);
    arbitration->callback([&] { status = run_arbitration(options); });
    auto* web = app.add_subcommand(
        "web",
        "the web endpoint's cost: one-hop latency and throughput without --http and with idle "
        "connections and an /api/stream reader; plexusd CPU/s of the stream with the fetch robot running");
    add_common(web);
    web->add_option("--idle", options.idle_connections, "idle TCP connections to the web endpoint")
        ->check(CLI::Range(0, 200))
        ->capture_default_str();
    web->add_option("--stream-count", options.stream_count,
                    "messages per throughput run (default: by size); --count sets the round trips")
        ->check(CLI::PositiveNumber);
    options.plexus_cli = PLEXUS_CLI_PATH;
    options.app_file = std::string(PLEXUS_SOURCE_DIR) + "/configs/apps/fetch.json";
    web->add_option("--plexus", options.plexus_cli, "the plexus CLI (it runs `plexus up`)")
        ->capture_default_str();
    web->add_option("--app", options.app_file, "the application the stream's cost is measured with")
        ->capture_default_str();
    web->add_option("--window", options.window_s, "seconds of each CPU window of the stream's cost")
        ->check(CLI::Range(0.5, 50.0))
        ->capture_default_str();
    web->add_option("--cost-repeat", options.cost_repeat,
                    "CPU windows per variant (without, with the stream)")
        ->check(CLI::Range(0, 50))
        ->capture_default_str();
    web->callback([&] { status = run_web(options); });
    auto* record = app.add_subcommand(
        "record",
        "recording (issue 28): MB/s into a file against dd to the same directory; one-hop latency and "
        "throughput without, with and again without a recording; plexus what-if in messages/s");
    record->add_option("--repeat", options.repeat, "runs per figure; medians are reported")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    record->add_option("--dir", options.record_dir,
                       "directory for the recordings and dd's files (default: a fresh one under /tmp, "
                       "removed afterwards); its disk is the one measured");
    record->add_option("--mib", options.record_mib, "1 MiB messages per recording-throughput run")
        ->check(CLI::Range(std::size_t{4}, std::size_t{4096}))
        ->capture_default_str();
    record
        ->add_option("--what-if-rounds", options.what_if_rounds,
                     "rounds of writes in the what-if recording (3 or 4 messages each, 200 us apart)")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    record->add_option("--count", options.count, "round trips per latency run (default: by size)")
        ->check(CLI::PositiveNumber);
    record
        ->add_option("--stream-count", options.stream_count,
                     "messages per 64 B throughput run (default 1,000,000; 64 KiB: by size)")
        ->check(CLI::PositiveNumber);
    record->add_option("--baseline-plexusd", options.baseline_plexusd,
                       "data-path: also run each scenario on this plexusd (one built from the commit "
                       "before the recording tap, 8cd2c9d), alternated: the '0% when no one records' check");
    record->add_option("--parts", options.parts, "throughput, data-path, what-if (default: all)")
        ->delimiter(',')
        ->check(CLI::IsMember({"throughput", "data-path", "what-if"}));
    options.scripts_dir = std::string(PLEXUS_SOURCE_DIR) + "/configs/monitors";
    record->add_option("--scripts", options.scripts_dir, "the monitor scripts (what-if's Lua carriers)")
        ->capture_default_str();
    record->add_option("--plexus", options.plexus_cli, "the plexus CLI (it runs what-if)")
        ->capture_default_str();
    record
        ->add_option("--capacity", options.capacity, "reader queue length asked of plexusd (0: its default)")
        ->capture_default_str();
    record->add_flag("--json", options.json, "one JSON object per line");
    record->add_option("--plexusd", options.plexusd, "the plexusd binary")->capture_default_str();
    record->callback([&] { status = run_record(options); });
    auto* memory = app.add_subcommand("memory", "plexusd resident memory, idle and with many ports open");
    memory->add_option("--ports", options.ports, "ports to open")->capture_default_str();
    memory->add_flag("--json", options.json, "one JSON object per line");
    memory->add_option("--plexusd", options.plexusd, "the plexusd binary")->capture_default_str();
    bool burst = false;
    memory->add_flag(
        "--burst", burst,
        "instead: --ports streams fill their queues (--capacity, default 1024 messages of --size "
        "bytes) into stalled readers, then close; RSS idle, at the peak and after");
    memory->add_option("--size", options.size, "with --burst: bytes per message")->capture_default_str();
    memory->add_option("--capacity", options.capacity, "with --burst: messages per stream");
    memory->callback([&] { status = burst ? run_memory_burst(options) : run_memory(options); });

    auto* memcpy_command = app.add_subcommand(
        "memcpy",
        "this machine's memcpy rate for the payload size, warm and cold: the yardstick for large messages");
    memcpy_command->add_option("--size", options.size, "bytes per copy")->capture_default_str();
    memcpy_command->add_option("--repeat", options.repeat, "runs; medians are reported")
        ->capture_default_str();
    memcpy_command->add_flag("--json", options.json, "one JSON object");
    memcpy_command->callback([&] { status = run_memcpy(options); });

    peers::PeersOptions peers_options;
    peers_options.plexusd = PLEXUSD_PATH;
    auto* peers = app.add_subcommand(
        "peers",
        "Plexus, Mosquitto, NATS, ZeroMQ (proxy), Redis, Cyclone DDS (reliable, best effort) and iceoryx "
        "doing the same jobs, in the same run (DDS needs root: a network namespace of its own)");
    peers->add_flag("--quick", peers_options.quick, "a tenth of the messages and one run per system");
    peers->add_flag("--json", peers_options.json, "one JSON object per row");
    peers->add_option("--repeat", peers_options.repeat, "runs per system and row; medians are reported")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    peers->add_option("--sizes", peers_options.sizes, "payload sizes in bytes (at least 24)")
        ->check(CLI::Range(std::size_t{24}, std::size_t{32} << 20))
        ->delimiter(',')
        ->capture_default_str();
    peers->add_option("--systems", peers_options.systems, "systems to run (default: all built in)")
        ->delimiter(',');
    peers
        ->add_option("--scenarios", peers_options.scenarios,
                     "pingpong, rate_1khz, throughput, fanout_8 (default: these four), requestreply (Plexus "
                     "calls against NATS requests: --systems plexus,nats)")
        ->delimiter(',');
    peers
        ->add_option("--count", peers_options.count, "messages or round trips per run (default: by scenario)")
        ->check(CLI::PositiveNumber);
    peers->add_option("--plexusd", peers_options.plexusd, "the plexusd binary")->capture_default_str();
    peers->callback([&] {
        // A peer's client library may write to a server that just went away (hiredis uses plain
        // write()); that must be an error of the run, not the end of the bench.
        ::signal(SIGPIPE, SIG_IGN);
        status = peers::run_peers(peers_options);
    });

    HostsOptions hosts_options;
    hosts_options.plexusd = PLEXUSD_PATH;
    auto* hosts = app.add_subcommand(
        "hosts",
        "tcp, udp and mcast between daemons on separate hosts (network namespaces; needs root), each "
        "against direct sockets over the same veth; mcast fan-out on the wire; the cost of the secret");
    hosts->add_flag("--quick", hosts_options.quick, "a tenth of the messages and one run per system");
    hosts->add_option("--repeat", hosts_options.repeat, "runs per system; medians are reported")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    hosts->add_flag("--json", hosts_options.json, "one JSON object per line and system");
    hosts->add_option("--plexusd", hosts_options.plexusd, "the plexusd binary")->capture_default_str();
    hosts->add_option("--plexus-names", hosts_options.plexus_names,
                      "the plexus-names binary (default: next to plexusd)");
    hosts->add_flag("--calls", hosts_options.calls,
                    "instead of the other parts: call round trips from host 1 to a port served on host 2 "
                    "at 64 B, 64 KiB and 1 MiB, against the relay floor with the same hops and direct TCP");
    hosts->callback([&] { status = run_hosts(hosts_options); });

    // Not for people: one run of a peers system in a process of its own (own_process_run.hpp).
    peers::PeerRunOptions run_options;
    run_options.plexusd = PLEXUSD_PATH;
    auto* peer_run = app.add_subcommand("peer-run", "")->group("");
    peer_run->add_option("--system", run_options.system)->required();
    peer_run->add_option("--scenario", run_options.scenario)->required();
    peer_run->add_option("--size", run_options.size)->required();
    peer_run->add_option("--count", run_options.count)->required();
    peer_run->add_option("--plexusd", run_options.plexusd);
    peer_run->callback([&] {
        ::signal(SIGPIPE, SIG_IGN);  // as for `peers`
        status = peers::run_peer_run(run_options);
    });
#ifdef PLEXUS_BENCH_PEERS
    // Not for people: the ZeroMQ proxy of the peers bench, a process of its own like every broker.
    std::string proxy_ready_file;
    auto* zmq_proxy = app.add_subcommand("zmq-proxy", "")->group("");
    zmq_proxy->add_option("--ready-file", proxy_ready_file)->required();
    zmq_proxy->callback([&] { status = peers::run_zmq_proxy(proxy_ready_file); });
    // Not for people: the far end of a DDS or iceoryx scenario (far_end.hpp).
    peers::FarEndOptions far_end_options;
    auto* far_end = app.add_subcommand("peer-far-end", "")->group("");
    far_end->add_option("--system", far_end_options.system)->required();
    far_end->add_option("--role", far_end_options.role)->required();
    far_end->add_option("--topic", far_end_options.topic)->required();
    far_end->add_option("--answer-topic", far_end_options.answer_topic);
    far_end->add_option("--report", far_end_options.report);
    far_end->add_option("--queue-capacity", far_end_options.queue_capacity);
    far_end->callback([&] { status = peers::run_far_end(far_end_options); });
#endif

    bridges::BridgesOptions bridges_options;
    bridges_options.plexusd = PLEXUSD_PATH;
    bridges_options.bridge = PLEXUS_BRIDGE_PATH;
    bridges_options.plexus = PLEXUS_CLI_PATH;
    auto* bridges_command = app.add_subcommand(
        "bridges",
        "plexus-bridge's added latency and sustained rate: DDS -> Plexus -> DDS against DDS through an echo "
        "of the same shape, MQTT -> Plexus -> MQTT against mosquitto the same way (a network namespace of "
        "its own; needs root)");
    bridges_command->add_flag("--quick", bridges_options.quick, "a tenth of the messages and one run");
    bridges_command->add_flag("--json", bridges_options.json, "one JSON object per row");
    bridges_command->add_option("--repeat", bridges_options.repeat, "runs per row; medians are reported")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    bridges_command->add_option("--sizes", bridges_options.sizes, "payload sizes in bytes (at least 8)")
        ->check(CLI::Range(std::size_t{8}, std::size_t{64} << 20))
        ->delimiter(',')
        ->capture_default_str();
    bridges_command->add_option("--links", bridges_options.links, "dds, mqtt (default: both)")
        ->delimiter(',')
        ->check(CLI::IsMember({"dds", "mqtt"}));
    bridges_command->add_option("--plexusd", bridges_options.plexusd, "the plexusd binary")
        ->capture_default_str();
    bridges_command->add_option("--bridge", bridges_options.bridge, "the plexus-bridge binary")
        ->capture_default_str();
    bridges_command->callback([&] { status = bridges::run_bridges(bridges_options); });

    // Not for people: the ends of the bridges bench's paths, processes of their own.
    bridges::EndOptions end_options;
    for (auto* end : {app.add_subcommand("bridge-ping", "")->group(""),
                      app.add_subcommand("bridge-echo", "")->group("")}) {
        end->add_option("--link", end_options.link);
        end->add_option("--out", end_options.out)->required();
        end->add_option("--in", end_options.in)->required();
        end->add_option("--broker", end_options.broker);
        end->add_option("--qos", end_options.qos);
        end->add_option("--size", end_options.size);
        end->add_option("--count", end_options.count);
        end->add_option("--stream", end_options.stream);
        end->add_option("--window", end_options.window);
        const bool ping = end->get_name() == "bridge-ping";
        end->callback(
            [&, ping] { status = ping ? bridges::run_ping(end_options) : bridges::run_echo(end_options); });
    }

    // Not for people: the bench starts itself with this to get a relay process for the floor.
    RelayOptions relay_options;
    auto* relay = app.add_subcommand("relay", "")->group("");
    relay->add_option("--socket", relay_options.socket)->required();
    relay->add_option("--ready-file", relay_options.ready_file)->required();
    relay->add_flag("--link-listen", relay_options.link_listen);
    relay->add_option("--link-connect", relay_options.link_connect);
    relay->add_flag("--udp-link", relay_options.udp_link);
    relay->add_option("--link-address", relay_options.link_address);
    relay->callback([&] { status = run_relay(relay_options); });

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    } catch (const std::exception& e) {
        std::cerr << "plexus-bench: " << e.what() << '\n';
        return 4;
    }
    return status;
}
