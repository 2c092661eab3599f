// The fetch-and-carry robot of the port-arbitration paper, brought up from configs/apps/fetch.json
// with `plexus up` and judged only by what the simulated world itself observes (/world/phase):
// the six phases in order, at least twice, for three seeds; recovery from a dropped object, a
// person who walks away and a hidden object; the same application split over two daemons.
// The world runs ten times faster than real time (SPEED=10).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace fetch_test {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

const std::vector<std::string> in_order{"search_object", "reach",    "grasp",
                                        "search_person", "approach", "release"};

std::string fetch_app() {
    return std::filesystem::canonical(monitors_dir() + "/../apps/fetch.json").string();
}

/// `plexus up|down|check FILE` against `daemon`, with SPEED/SEED (and more) in its environment.
CliResult app_command(const TempDir& dir, const Daemon& daemon, const std::string& command,
                      const std::map<std::string, std::string>& vars,
                      const std::vector<std::string>& more = {}) {
    static int counter = 0;
    auto env = daemon.env();
    env.insert(vars.begin(), vars.end());
    std::vector<std::string> argv{plexus_path(), command, fetch_app()};
    argv.insert(argv.end(), more.begin(), more.end());
    Process process(argv, env, dir.file("app-" + command + std::to_string(counter++)));
    const auto status = process.wait(120s);
    return {status.value_or(-1), process.out(), process.err()};
}

/// What the world says it observes, read through a port of the test's own.
class PhaseWatch {
public:
    PhaseWatch(const Daemon& daemon, const std::string& name = "/test/phase")
        : client_({daemon.socket()}),
          port_(client_.open(name, {.capacity = 4096})),
          control_(client_.open(name + "/control")) {
        client_.connect("/world/phase", name);
        client_.connect(name + "/control", "/world/control");
    }

    struct Seen {
        std::string phase;
        double t = 0;  ///< world (simulated) seconds
        int deliveries = 0;
        Clock::time_point at;  ///< when the test received it
    };

    /// Reads phase messages until `done` holds for what was seen, or `timeout` passes.
    bool read_until(const std::function<bool(const std::vector<Seen>&)>& done, std::chrono::seconds timeout) {
        const auto deadline = Clock::now() + timeout;
        while (!done(seen_)) {
            if (Clock::now() >= deadline)
                return false;
            auto message = port_.read(200ms);
            if (!message)
                continue;
            const auto& data = message->data;
            seen_.push_back({data.at("phase").get<std::string>(), data.at("t").get<double>(),
                             data.value("deliveries", 0), Clock::now()});
        }
        return true;
    }
    /// Waits for the next phase message naming `phase` (after those seen so far).
    bool next(const std::string& phase, std::chrono::seconds timeout) {
        const std::size_t from = seen_.size();
        return read_until(
            [&](const std::vector<Seen>& seen) {
                for (std::size_t i = from; i < seen.size(); ++i)
                    if (seen[i].phase == phase)
                        return true;
                return false;
            },
            timeout);
    }
    /// Reads whatever comes for `duration`: an observation window, not a wait for an outcome.
    void read_for(std::chrono::seconds duration) {
        read_until([](const std::vector<Seen>&) { return false; }, duration);
    }
    void disturb(const json& what) { control_.write(what); }
    const std::vector<Seen>& seen() const { return seen_; }
    std::string history(std::size_t from = 0) const {
        std::string text;
        for (std::size_t i = from; i < seen_.size(); ++i)
            text += seen_[i].phase + "@" + std::to_string(seen_[i].t) + " ";
        return text;
    }

private:
    Client client_;
    Port port_;
    Port control_;
    std::vector<Seen> seen_;
};

/// How many times the six phases happened in order (a subsequence of what was seen).
int complete_cycles(const std::vector<PhaseWatch::Seen>& seen) {
    int cycles = 0;
    std::size_t want = 0;
    for (const auto& s : seen) {
        if (s.phase == in_order[want] && ++want == in_order.size()) {
            ++cycles;
            want = 0;
        }
    }
    return cycles;
}

/// A daemon with the shipped monitors, the application up at SPEED=10 with `seed`, and down at
/// the end (also when the test fails).
struct FetchRobot {
    explicit FetchRobot(int seed) : daemon(dir, "robot", "", {"--scripts", monitors_dir()}) {
        vars = {{"SPEED", "10"}, {"SEED", std::to_string(seed)}};
        up = app_command(dir, daemon, "up", vars);
    }
    ~FetchRobot() {
        if (up.status != 0)
            return;
        const auto result = app_command(dir, daemon, "down", vars);
        EXPECT_EQ(result.status, 0) << "plexus down left the application running: " << result.err;
    }
    TempDir dir;
    Daemon daemon;
    std::map<std::string, std::string> vars;
    CliResult up;
};

class Fetch_test : public ::testing::TestWithParam<int> {};

TEST_P(Fetch_test, TheSixPhasesHappenInOrderAtLeastTwice) {
    FetchRobot robot(GetParam());
    ASSERT_EQ(robot.up.status, 0) << robot.up.out << robot.up.err;
    PhaseWatch phases(robot.daemon);
    const auto began = Clock::now();
    ASSERT_TRUE(phases.read_until([](const auto& seen) { return complete_cycles(seen) >= 2; }, 150s))
        << phases.history();
    // A delivery shows in the message after its release (the world counts it as the hand opens).
    ASSERT_TRUE(phases.next("search_object", 60s)) << phases.history();
    const auto& seen = phases.seen();
    EXPECT_GE(seen.back().deliveries, 2) << phases.history();
    for (const auto& phase : in_order) {
        EXPECT_GE(std::count_if(seen.begin(), seen.end(), [&](const auto& s) { return s.phase == phase; }), 2)
            << phase;
    }
    std::printf("[ fetch seed %d ] two full cycles in %.1f s of world time (%.1f s real): %s\n", GetParam(),
                seen.back().t - seen.front().t, std::chrono::duration<double>(Clock::now() - began).count(),
                phases.history().c_str());

    // down takes it all away: no port of the application is left.
    auto down = app_command(robot.dir, robot.daemon, "down", robot.vars);
    EXPECT_EQ(down.status, 0) << down.err;
    robot.up.status = -1;  // already down
    auto list = run_cli(robot.dir, robot.daemon, {"list", "--json"});
    ASSERT_EQ(list.status, 0);
    const auto listed = json::parse(list.out);  // named: a range-for over a temporary's member dangles
    for (const auto& port : listed["ports"]) {
        const std::string name = port["name"];
        EXPECT_TRUE(name.rfind("/test/", 0) == 0) << name << " is still there after down";
    }
}

INSTANTIATE_TEST_SUITE_P(Seeds, Fetch_test, ::testing::Values(1, 2, 3));

double world_seconds_between(const PhaseWatch::Seen& a, const PhaseWatch::Seen& b) {
    return b.t - a.t;
}

TEST(FetchDisturbance_test, ADroppedObjectIsGraspedAgainAndDelivered) {
    FetchRobot robot(4);
    ASSERT_EQ(robot.up.status, 0) << robot.up.out << robot.up.err;
    PhaseWatch phases(robot.daemon);
    // Dropped during transport: while the arm carries the object to the person.
    ASSERT_TRUE(phases.next("approach", 120s)) << phases.history();
    const int delivered_before = phases.seen().back().deliveries;
    const std::size_t at_drop = phases.seen().size();
    const auto dropped = Clock::now();
    phases.disturb({{"drop", true}});
    ASSERT_TRUE(phases.next("grasp", 60s)) << phases.history(at_drop);
    const auto regrasped = phases.seen().back();
    ASSERT_TRUE(phases.next("release", 60s)) << phases.history(at_drop);
    // Delivered: the release after the drop ends with one more delivery.
    ASSERT_TRUE(phases.next("search_object", 60s)) << phases.history(at_drop);
    EXPECT_EQ(phases.seen().back().deliveries, delivered_before + 1) << phases.history(at_drop);
    // Between the drop and the new grasp the robot searched for the object or reached for it.
    bool searched = false;
    for (std::size_t i = at_drop; i < phases.seen().size(); ++i)
        searched = searched || phases.seen()[i].phase == "search_object" || phases.seen()[i].phase == "reach";
    EXPECT_TRUE(searched) << phases.history(at_drop);
    std::printf("[ drop ] grasped again %.2f s of world time (%.0f ms real) after the drop: %s\n",
                world_seconds_between(phases.seen()[at_drop > 0 ? at_drop - 1 : 0], regrasped),
                std::chrono::duration<double, std::milli>(regrasped.at - dropped).count(),
                phases.history(at_drop).c_str());
}

TEST(FetchDisturbance_test, APersonWhoLeavesIsSearchedForWhileTheObjectIsHeld) {
    FetchRobot robot(5);
    ASSERT_EQ(robot.up.status, 0) << robot.up.out << robot.up.err;
    PhaseWatch phases(robot.daemon);
    // The person leaves while the robot carries the object to them. If the release came first
    // (the world is fast, the test may be slow), the object is gone: try again with the next one.
    std::size_t at_leave = 0;
    for (int attempt = 0;; ++attempt) {
        ASSERT_LT(attempt, 5) << "the person never left while the object was held: " << phases.history();
        ASSERT_TRUE(phases.next("approach", 120s)) << phases.history();
        const int deliveries = phases.seen().back().deliveries;
        at_leave = phases.seen().size();
        phases.disturb({{"person", "away"}});
        ASSERT_TRUE(phases.next("search_person", 60s)) << phases.history(at_leave);
        if (phases.seen().back().deliveries == deliveries)
            break;
        phases.disturb({{"person", "back"}});
    }
    const std::size_t searching_at = phases.seen().size() - 1;
    const double searching_since = phases.seen().back().t;
    // While the person is away the robot keeps the object and searches: 20 s of world time (2 s
    // real) with no approach and no release. Read for that long; nothing else may happen.
    phases.read_for(2s);
    for (std::size_t i = searching_at; i < phases.seen().size(); ++i) {
        EXPECT_NE(phases.seen()[i].phase, "approach") << phases.history(at_leave);
        EXPECT_NE(phases.seen()[i].phase, "release") << phases.history(at_leave);
    }
    const std::size_t at_back = phases.seen().size();
    const auto back = Clock::now();
    phases.disturb({{"person", "back"}});
    ASSERT_TRUE(phases.next("release", 60s)) << phases.history(at_back);
    const auto released = phases.seen().back();
    std::printf(
        "[ person away ] searched %.1f s of world time while holding; released %.0f ms (real) after "
        "the person came back: %s\n",
        released.t - searching_since, std::chrono::duration<double, std::milli>(released.at - back).count(),
        phases.history(at_leave).c_str());
}

TEST(FetchDisturbance_test, AHiddenObjectIsSearchedForAgain) {
    FetchRobot robot(6);
    ASSERT_EQ(robot.up.status, 0) << robot.up.out << robot.up.err;
    PhaseWatch phases(robot.daemon);
    ASSERT_TRUE(phases.next("reach", 120s)) << phases.history();
    const std::size_t at_hide = phases.seen().size();
    const auto hidden = Clock::now();
    phases.disturb({{"hide", true}});
    ASSERT_TRUE(phases.next("search_object", 30s)) << phases.history(at_hide);
    ASSERT_TRUE(phases.next("grasp", 60s)) << phases.history(at_hide);
    const auto grasped = phases.seen().back();
    std::printf(
        "[ hide ] grasped %.0f ms (real) after the object was hidden (3 s of world time hidden): %s\n",
        std::chrono::duration<double, std::milli>(grasped.at - hidden).count(),
        phases.history(at_hide).c_str());
}

TEST(FetchTwoDaemons_test, SensorsOnOneNodeAndActuatorsOnAnotherBehaveTheSame) {
    TempDir dir;
    Daemon sensors(dir, "sensors", "", {"--scripts", monitors_dir()});
    Daemon actuators(dir, "actuators", sensors.names(), {"--scripts", monitors_dir()});
    const std::map<std::string, std::string> vars{
        {"SPEED", "10"}, {"SEED", "7"}, {"SENSORS_NODE", "sensors"}, {"ACTUATORS_NODE", "actuators"}};
    auto up = app_command(dir, sensors, "up", vars, {"--node-socket", "actuators=" + actuators.socket()});
    ASSERT_EQ(up.status, 0) << up.out << up.err;
    // down finds what up started in its state file: it needs no sockets of other nodes.
    struct Down {
        std::function<void()> run;
        ~Down() { run(); }
    } down{[&] {
        const auto result = app_command(dir, sensors, "down", vars);
        EXPECT_EQ(result.status, 0) << "plexus down left the application running: " << result.err;
    }};
    // The arbitrated ports live on the actuators' daemon, the sensors on the other.
    auto list = run_cli(dir, sensors, {"list", "--json"});
    ASSERT_EQ(list.status, 0);
    const auto listed = json::parse(list.out);  // named: a range-for over a temporary's member dangles
    for (const auto& port : listed["ports"]) {
        const std::string name = port["name"];
        if (name == "/arm/in" || name == "/gaze/in" || name == "/hand/in")
            EXPECT_EQ(port["node"], "actuators") << name;
        if (name == "/world/object" || name == "/world/touch")
            EXPECT_EQ(port["node"], "sensors") << name;
    }
    PhaseWatch phases(sensors);
    ASSERT_TRUE(phases.read_until([](const auto& seen) { return complete_cycles(seen) >= 2; }, 150s))
        << phases.history();
    std::printf("[ two daemons ] two full cycles: %s\n", phases.history().c_str());
}

}  // namespace fetch_test
}  // namespace plexus::test
