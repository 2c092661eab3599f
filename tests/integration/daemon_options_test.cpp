// The numeric options of plexusd and plexus-names: negatives, NaN, infinities, fractions, huge
// numbers and text are refused at start-up with exit 2 and one line naming the option -- never
// taken as a wrapped-around 2^64-5 threads or a negative grace. Each run has a deadline: a
// program that accepted the value is still running then (serving), and is killed.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "harness.hpp"

namespace plexus::test {
namespace daemon_options_test {

const std::vector<std::string> bad_values{"-5",
                                          "-1",
                                          "nan",
                                          "inf",
                                          "-inf",
                                          "1.5",
                                          "1e3",
                                          "abc",
                                          "",
                                          "0x10",
                                          "99999999999999999999",
                                          "18446744073709551611"};

struct Outcome {
    std::optional<int> status;
    std::string err;
};

/// Runs `argv` until it exits or the deadline passes (then it is killed: nullopt).
Outcome run_with_deadline(const TempDir& dir, const std::vector<std::string>& argv, const std::string& name) {
    Process process(argv, {}, dir.file(name));
    auto status = process.wait(10s);
    return {status, process.err()};
}

TEST(DaemonOptions_test, PlexusdRefusesBadMonitorThreads) {
    TempDir dir;
    int run = 0;
    for (const auto& value : bad_values) {
        // A socket and a name server of its own in the scratch directory, on free ports: a daemon
        // that wrongly starts disturbs nothing, and is killed at the deadline.
        const std::vector<std::string> argv{plexusd_path(),
                                            "--embedded-names",
                                            "--names",
                                            "127.0.0.1:0",
                                            "--listen",
                                            "127.0.0.1:0",
                                            "--socket",
                                            dir.file("s" + std::to_string(run) + ".sock"),
                                            "--node",
                                            "n" + std::to_string(run),
                                            "--monitor-threads",
                                            value};
        auto outcome = run_with_deadline(dir, argv, "plexusd-" + std::to_string(run++));
        EXPECT_EQ(outcome.status, std::optional<int>(2))
            << "--monitor-threads '" << value << "': " << outcome.err;
        EXPECT_NE(outcome.err.find("--monitor-threads"), std::string::npos) << value << ": " << outcome.err;
    }
}

TEST(DaemonOptions_test, PlexusdStillTakesSensibleMonitorThreads) {
    TempDir dir;
    for (const std::string value : {"0", "1", "4"}) {
        Daemon daemon(dir, "threads" + value, "", {"--monitor-threads", value});  // waits until ready
        EXPECT_TRUE(daemon.process().running()) << value;
    }
}

TEST(DaemonOptions_test, NameServerRefusesBadNumbers) {
    TempDir dir;
    int run = 0;
    for (const std::string option : {"--grace-ms", "--handshake-timeout-ms", "--mcast-port"}) {
        for (const auto& value : bad_values) {
            const std::vector<std::string> argv{names_path(), "--listen", "127.0.0.1:0", option, value};
            auto outcome = run_with_deadline(dir, argv, "names-" + std::to_string(run++));
            EXPECT_EQ(outcome.status, std::optional<int>(2))
                << option << " '" << value << "': " << outcome.err;
            EXPECT_NE(outcome.err.find(option), std::string::npos)
                << option << " " << value << ": " << outcome.err;
        }
    }
}

// spdlog reads an unknown level name as "off": `--log-level bogus` ran a daemon that said nothing.
TEST(DaemonOptions_test, AnUnknownLogLevelIsRefused) {
    TempDir dir;
    for (const auto& program : {plexusd_path(), names_path()}) {
        const std::vector<std::string> argv{
            program,    "--embedded-names", "--names",     "127.0.0.1:0", "--socket", dir.file("level.sock"),
            "--listen", "127.0.0.1:0",      "--log-level", "bogus"};
        std::vector<std::string> names_argv{program, "--listen", "127.0.0.1:0", "--log-level", "bogus"};
        auto outcome = run_with_deadline(dir, program == names_path() ? names_argv : argv, "level");
        EXPECT_EQ(outcome.status, std::optional<int>(2)) << program << ": " << outcome.err;
        EXPECT_NE(outcome.err.find("--log-level"), std::string::npos) << outcome.err;
    }
}

}  // namespace daemon_options_test
}  // namespace plexus::test
