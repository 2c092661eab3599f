// plexus-bench record: what recording a port costs and how fast it writes (issue 28).
//
// 1. Recording throughput. A writer streams --mib messages of 1 MiB of random bytes into a
//    port that a reader drains, while the daemon records that port into a file under --dir. MB/s =
//    the file's bytes / the time from the first write to record_stop's reply (it replies once the
//    file is closed and synced). Alternated with the same bytes written by dd into the same
//    directory: from a random file in /dev/shm (RAM, not the disk measured) with one fdatasync at the
//    end, which is what the recorder does too (mcap::Writer::close syncs once) — the floor; and
//    from /dev/zero, for comparison with the usual dd figure.
// 2. The data path. `latency` (64 B) and `throughput` (64 B, 64 KiB) on one daemon, each run
//    three times in a row: no recording, a recording of the reading ports, no recording again (the
//    "nothing left behind" check). Medians and ratios to the first.
// 3. what-if speed. A recording of two arbitrated ports made here (the gaze demo's priority
//    carriers, and the two-trackers example's Lua certainty monitors with events and constraints),
//    then `plexus what-if FILE PORT --json` on each, timed: recorded messages per second of wall time.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "hosts_network.hpp"
#include "plexus/client.hpp"
#include "plexus_measurements.hpp"
#include "record_scenario.hpp"
#include "run_deadline.hpp"
#include "scenarios.hpp"
#include "topology.hpp"

namespace plexus::bench {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using nlohmann::ordered_json;

constexpr std::size_t mib = std::size_t{1} << 20;
// Distinct random messages cycled by the writer: more than a 4 MiB chunk holds, so that zstd
// (whose level-1 window is far smaller anyway) never sees a repeat within what it compresses.
constexpr std::size_t distinct_messages = 16;

double seconds_since(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// ---------------------------------------------------------------- 1. recording throughput

struct ThroughputRun {
    double record_mb_per_s = 0;     ///< file bytes / (first write .. record_stop's reply)
    double data_path_mb_per_s = 0;  ///< payload / (first write .. the reader's last message)
    double close_s = 0;             ///< the reader's last message .. record_stop's reply
    double file_mb = 0;
    Value status;
};

/// A writer and a reader on one daemon, connected once; each run() records the reader's port.
class RecordedStream {
public:
    RecordedStream(const Topology& topology, std::size_t capacity)
        : writer_(connect_client(topology.near_socket())),
          reader_(connect_client(topology.near_socket())),
          source_(writer_.open("/bench/record-source")),
          sink_(reader_.open("/bench/record-sink", {QueuePolicy::strict, capacity})) {
        connect_when_registered(writer_, source_.name(), sink_.name());
    }

    ThroughputRun run(OutputDir& dir, const std::vector<Value>& payloads, std::size_t messages) {
        Recording recording(reader_, {sink_.name()}, dir.next("record", ".mcap"));
        std::string error;
        Clock::time_point last_read;
        const auto start = Clock::now();
        std::jthread drain([&] {
            try {
                for (std::size_t i = 0; i < messages; ++i) {
                    if (!sink_.read(10s))
                        throw std::runtime_error("message " + std::to_string(i) + " never arrived");
                }
                last_read = Clock::now();
            } catch (const std::exception& e) {
                error = e.what();
            }
        });
        for (std::size_t i = 0; i < messages; ++i)
            source_.write(payloads[i % payloads.size()], false);
        source_.flush();
        drain.join();
        if (!error.empty())
            throw std::runtime_error("record throughput: " + error);
        ThroughputRun run;
        run.status = recording.stop();
        const auto closed = Clock::now();
        const auto bytes = file_size(recording.path());
        std::filesystem::remove(recording.path());
        check_kept(run.status, messages, "record throughput");
        const double total_s = std::chrono::duration<double>(closed - start).count();
        run.record_mb_per_s = static_cast<double>(bytes) / 1e6 / total_s;
        run.data_path_mb_per_s = static_cast<double>(messages * mib) / 1e6 /
                                 std::chrono::duration<double>(last_read - start).count();
        run.close_s = std::chrono::duration<double>(closed - last_read).count();
        run.file_mb = static_cast<double>(bytes) / 1e6;
        return run;
    }

private:
    Client writer_;
    Client reader_;
    Port source_;
    Port sink_;
};

/// dd into the directory; MB/s of what it wrote over its whole run (the fdatasync included).
double dd_mb_per_s(OutputDir& dir, const std::vector<std::string>& input, std::size_t messages) {
    const std::string output = dir.next("dd", ".bin");
    std::vector<std::string> argv{"/usr/bin/dd"};
    argv.insert(argv.end(), input.begin(), input.end());
    argv.insert(argv.end(), {"of=" + output, "bs=1M", "count=" + std::to_string(messages), "conv=fdatasync",
                             "status=none"});
    const auto start = Clock::now();
    const auto result = run_command(argv);
    const double elapsed = seconds_since(start);
    const auto bytes = file_size(output);
    std::filesystem::remove(output);
    if (result.status != 0 || bytes != messages * mib)
        throw std::runtime_error("dd failed (" + std::to_string(result.status) + "): " + result.output);
    return static_cast<double>(bytes) / 1e6 / elapsed;
}

}  // namespace

void measure_record_throughput(const Options& options) {
    OutputDir dir(options.record_dir);
    TempDir scratch;
    const auto topology = Topology::plexus(scratch, options.plexusd, 1);
    const std::size_t messages = options.record_mib;

    std::mt19937_64 random(28);
    std::vector<Value> payloads;
    for (std::size_t k = 0; k < distinct_messages; ++k) {
        std::vector<std::uint8_t> bytes(mib);
        for (std::size_t i = 0; i < mib; i += 8) {
            const std::uint64_t word = random();
            std::memcpy(bytes.data() + i, &word, 8);
        }
        payloads.push_back(Value::binary(std::move(bytes)));
    }
    // dd's source: the same kind of bytes, in RAM (tmpfs), so that reading it costs a copy, as the
    // recorder's bytes cost one out of the socket or shared memory.
    const std::string random_file = "/dev/shm/plexus-bench-" + std::to_string(::getpid()) + ".bin";
    {
        std::ofstream out(random_file, std::ios::binary);
        for (std::size_t i = 0; i < messages; ++i) {
            const auto& blob = payloads[i % payloads.size()].get_binary();
            out.write(reinterpret_cast<const char*>(blob.data()), static_cast<std::streamsize>(blob.size()));
        }
        if (!out)
            throw std::runtime_error("cannot write " + random_file);
    }
    struct RemoveFile {
        std::string path;
        ~RemoveFile() { std::filesystem::remove(path); }
    } remove_random{random_file};

    std::vector<double> recorder, data_path, close_s, dd_random, dd_zero;
    std::vector<ThroughputRun> runs;
    RecordedStream stream(*topology, options.capacity);
    {
        RunDeadline warm;
        stream.run(dir, payloads, std::max<std::size_t>(messages / 10, 4));  // warm-up: buffers, shm
    }
    for (int run = 0; run < options.repeat; ++run) {
        RunDeadline per_run;
        runs.push_back(stream.run(dir, payloads, messages));
        recorder.push_back(runs.back().record_mb_per_s);
        data_path.push_back(runs.back().data_path_mb_per_s);
        close_s.push_back(runs.back().close_s);
        dd_random.push_back(dd_mb_per_s(dir, {"if=" + random_file}, messages));
        dd_zero.push_back(dd_mb_per_s(dir, {"if=/dev/zero"}, messages));
    }
    const auto& last = runs.back();
    std::uint64_t lost = 0, not_recordable = 0;
    for (const auto& run : runs) {
        lost += status_count(run.status, "lost_messages");
        not_recordable += status_count(run.status, "not_recordable");
    }
    const double ratio = median(recorder) / median(dd_random);
    if (options.json) {
        std::cout << ordered_json{{"scenario", "record_throughput"},
                                  {"dir", dir.path()},
                                  {"messages", messages},
                                  {"message_bytes", mib},
                                  {"file_mb", last.file_mb},
                                  {"record_mb_per_s", median(recorder)},
                                  {"dd_random_tmpfs_mb_per_s", median(dd_random)},
                                  {"dd_zero_mb_per_s", median(dd_zero)},
                                  {"record_over_dd", ratio},
                                  {"data_path_mb_per_s", median(data_path)},
                                  {"close_s", median(close_s)},
                                  {"lost_messages", lost},
                                  {"not_recordable", not_recordable},
                                  {"last_status", last.status}}
                         .dump()
                  << '\n';
        return;
    }
    std::printf(
        "recording throughput into %s: %zu messages of 1 MiB of random bytes, median of %d "
        "runs, alternated with dd\n",
        dir.path().c_str(), messages, options.repeat);
    std::printf("  %-52s %10.1f MB/s\n", "plexusd recording (file bytes / first write..closed)",
                median(recorder));
    std::printf("  %-52s %10.1f MB/s\n", "dd if=<random file in /dev/shm> conv=fdatasync", median(dd_random));
    std::printf("  %-52s %10.1f MB/s\n", "dd if=/dev/zero conv=fdatasync", median(dd_zero));
    std::printf("  %-52s %10.2f\n", "recording / dd (random)", ratio);
    std::printf("  %-52s %10.1f MB/s\n", "the data path meanwhile (payload / first..last read)",
                median(data_path));
    std::printf("  %-52s %10.2f s\n", "last read .. record_stop's reply (drain, sync)", median(close_s));
    auto runs_text = [](const std::vector<double>& values) {
        std::string text;
        for (const double value : values) {
            char number[32];
            std::snprintf(number, sizeof number, " %.0f", value);
            text += number;
        }
        return text;
    };
    std::printf("  each run's MB/s: recording%s | dd (random)%s | dd (zero)%s\n", runs_text(recorder).c_str(),
                runs_text(dd_random).c_str(), runs_text(dd_zero).c_str());
    std::printf(
        "  recorder's counts (last run): %llu messages, %llu bytes; over all runs: %llu lost, "
        "%llu not recordable\n\n",
        static_cast<unsigned long long>(status_count(last.status, "messages")),
        static_cast<unsigned long long>(status_count(last.status, "bytes")),
        static_cast<unsigned long long>(lost), static_cast<unsigned long long>(not_recordable));
    std::fflush(stdout);
}

int run_record(const Options& options) {
    const auto wants = [&](const std::string& part) {
        return options.parts.empty() ||
               std::find(options.parts.begin(), options.parts.end(), part) != options.parts.end();
    };
    if (wants("throughput"))
        measure_record_throughput(options);
    if (wants("data-path"))
        measure_record_data_path(options);
    if (wants("what-if"))
        measure_what_if(options);
    return 0;
}

}  // namespace plexus::bench
