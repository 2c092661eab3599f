// plexus-bench streams: how the daemon's data path holds up as independent streams add up.
// One daemon; S streams (default 1, 10, 100, 1,000), each a local connection from a port of its
// own to a port of its own. The streams are spread over C writer clients and C reader clients
// (C = min(S, --clients), each client its own session with the daemon, as separate components
// would be), one thread each: a writer writes one 64 B message on each of its ports in turn,
// round after round, flushing every 16 rounds; a reader reads its ports in the same order. Figures:
// deliveries per second over all streams (first write to last read), and the CPU time the daemon
// and this process spent per message, against one stream in the same run. The daemon's own CPU
// per message is printed apart: it is what a second daemon thread could share.
//
// --daemon-threads 1,2 runs the rows against a daemon of each kind (plexusd --threads), their runs
// alternating. All writer clients connect before the reader clients, so with N data threads and
// C clients a multiple of N, stream s's writer and reader land on the same thread (sessions go to
// the threads in turn): independent streams, what threads are for. With one client pair (the
// 1-stream row) they land on two threads, and every message crosses between them.
#include <algorithm>
#include <chrono>
#include <iostream>
#include <stdexcept>
#include <thread>

#include <unistd.h>

#include "measurement.hpp"
#include "plexus/client.hpp"
#include "process_stats.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

constexpr int flush_every = 16;  ///< rounds between flushes: well below the queues' default length

struct StreamsRun {
    double msgs_per_s = 0;
    double cpu_us_per_msg = 0;     ///< the daemon's and this process's CPU time, per message
    double daemon_us_per_msg = 0;  ///< the daemon's alone
};

/// One client and the ports it writes or reads, in the order it visits them each round.
struct ClientPorts {
    std::unique_ptr<Client> client;
    std::vector<Port> ports;
};

StreamsRun run_once(const Topology& topology, int streams, int clients, int rounds, int run) {
    Client::Options options;
    options.socket = topology.near_socket();
    std::vector<ClientPorts> writers(static_cast<std::size_t>(clients));
    std::vector<ClientPorts> readers(static_cast<std::size_t>(clients));
    for (int c = 0; c < clients; ++c)
        writers[c].client = std::make_unique<Client>(options);
    for (int c = 0; c < clients; ++c)
        readers[c].client = std::make_unique<Client>(options);
    for (int s = 0; s < streams; ++s) {
        const std::string suffix =
            std::to_string(run) + "/" + std::to_string(streams) + "/" + std::to_string(s);
        auto& writer = writers[s % clients];
        auto& reader = readers[s % clients];
        writer.ports.push_back(writer.client->open("/streams/out/" + suffix));
        reader.ports.push_back(reader.client->open("/streams/in/" + suffix));
        writer.client->connect(writer.ports.back().name(), reader.ports.back().name(), "local");
    }
    const std::vector<pid_t> daemon = topology.pids();
    std::vector<pid_t> everyone = daemon;
    everyone.push_back(::getpid());
    const double cpu_before = cpu_seconds(everyone);
    const double daemon_before = cpu_seconds(daemon);
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(2 * clients));
    for (int c = 0; c < clients; ++c) {
        threads.emplace_back([&, c] {
            try {
                auto& ports = writers[c].ports;
                for (int round = 1; round <= rounds; ++round) {
                    const bool flush = round % flush_every == 0 || round == rounds;
                    for (std::size_t p = 0; p < ports.size(); ++p)
                        ports[p].write(Value(round), flush && p + 1 == ports.size());
                }
            } catch (...) {
                errors[2 * c] = std::current_exception();
            }
        });
        threads.emplace_back([&, c] {
            try {
                for (int round = 1; round <= rounds; ++round) {
                    for (auto& port : readers[c].ports) {
                        if (!port.read(std::chrono::seconds(30)))
                            throw std::runtime_error("streams: a reader waited 30 s for a message");
                    }
                }
            } catch (...) {
                errors[2 * c + 1] = std::current_exception();
            }
        });
    }
    for (auto& thread : threads)
        thread.join();
    for (const auto& error : errors) {
        if (error)
            std::rethrow_exception(error);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double messages = static_cast<double>(streams) * rounds;
    return {messages / seconds, (cpu_seconds(everyone) - cpu_before) * 1e6 / messages,
            (cpu_seconds(daemon) - daemon_before) * 1e6 / messages};
}

}  // namespace

int run_streams(const Options& options) {
    std::vector<std::unique_ptr<TempDir>> dirs;  // one each: a daemon's socket and files
    std::vector<std::unique_ptr<Topology>> daemons;
    for (const int threads : options.daemon_threads) {
        dirs.push_back(std::make_unique<TempDir>());
        daemons.push_back(
            Topology::plexus(*dirs.back(), options.plexusd, 1, {"--threads", std::to_string(threads)}));
    }
    const int total = options.count > 0 ? static_cast<int>(options.count) : 2000000;  // messages per run
    struct Row {
        std::size_t daemon;
        int streams;
        std::vector<double> rates, cpu, daemon_cpu;
    };
    std::vector<Row> rows;
    for (std::size_t d = 0; d < daemons.size(); ++d) {
        for (const int streams : options.streams)
            rows.push_back({d, streams, {}, {}, {}});
    }
    for (int run = 0; run < options.repeat; ++run) {
        for (const int streams : options.streams) {
            for (auto& row : rows) {  // the same row of each daemon, one after the other
                if (row.streams != streams)
                    continue;
                const int clients = std::min(row.streams, options.stream_clients);
                const int rounds = std::max(flush_every, total / row.streams);
                const StreamsRun result = run_once(*daemons[row.daemon], row.streams, clients, rounds, run);
                row.rates.push_back(result.msgs_per_s);
                row.cpu.push_back(result.cpu_us_per_msg);
                row.daemon_cpu.push_back(result.daemon_us_per_msg);
            }
        }
    }
    const double first = median(rows.front().rates);
    if (!options.json)
        std::cout << "streams: 64 B messages, about " << total << " per run over all streams, "
                  << options.stream_clients << " writer and reader clients at most, median of "
                  << options.repeat << " runs, " << std::thread::hardware_concurrency() << " cores\n";
    for (const auto& row : rows) {
        const double rate = median(row.rates);
        const int threads = options.daemon_threads[row.daemon];
        // Against the same number of streams on the first daemon (--daemon-threads' first).
        double same_on_first = rate;
        for (const auto& other : rows) {
            if (other.daemon == 0 && other.streams == row.streams)
                same_on_first = median(other.rates);
        }
        if (options.json)
            std::cout << R"({"scenario":"streams","threads":)" << threads << R"(,"streams":)" << row.streams
                      << R"(,"msgs_per_s":)" << rate << R"(,"against_first":)" << rate / first
                      << R"(,"against_first_daemon":)" << rate / same_on_first << R"(,"cpu_us_per_msg":)"
                      << median(row.cpu) << R"(,"daemon_cpu_us_per_msg":)" << median(row.daemon_cpu) << "}\n";
        else
            std::cout << "  --threads " << threads << ", " << row.streams
                      << " stream(s): " << static_cast<long>(rate) << " msgs/s, " << rate / first
                      << "x the first row, " << rate / same_on_first << "x the first daemon's, "
                      << median(row.cpu) << " us CPU per message (" << median(row.daemon_cpu)
                      << " in the daemon)\n";
    }
    return 0;
}

}  // namespace plexus::bench
