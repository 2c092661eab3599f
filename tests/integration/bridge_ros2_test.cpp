// plexus-bridge ros2 against DDS programs of the test's own (plexus-dds-probe), everything inside a
// network namespace host so that DDS discovery never touches this machine's interfaces.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "harness.hpp"
#include "netns.hpp"

namespace plexus::test {
namespace bridge_ros2_test {

std::string bridge_path() {
    return PLEXUS_BRIDGE_PATH;
}

std::string probe_path() {
    return PLEXUS_DDS_PROBE;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        lines.push_back(line);
    if (!text.empty() && text.back() != '\n' && !lines.empty())
        lines.pop_back();  // a line still being written
    return lines;
}

/// A host with a daemon (embedded name server) and a way to start DDS programs and the bridge in it.
struct RosHost {
    Network network{1};
    TempDir dir;
    Daemon daemon{dir, network.host(0), "robot", "", {"--scripts", monitors_dir()}};
    std::vector<std::unique_ptr<Process>> processes;
    /// The ROS 2 domain of the probes and the bridges this test starts (the namespace isolates them
    /// anyway; a domain other than 0 shows the bridge takes it).
    std::string domain = "7";

    Process& start(const std::vector<std::string>& argv, const std::string& name) {
        auto env = daemon.env();
        env["ROS_DOMAIN_ID"] = domain;
        processes.push_back(std::make_unique<Process>(network.host(0).wrap(argv), env, dir.file(name)));
        return *processes.back();
    }
    Process& bridge(const std::vector<std::string>& mappings) {
        std::vector<std::string> argv{bridge_path(), "ros2"};
        argv.insert(argv.end(), mappings.begin(), mappings.end());
        return start(argv, "bridge");
    }
    Process& probe(const std::string& command, const std::string& topic, const std::string& argument = "") {
        std::vector<std::string> argv{probe_path(), command, topic};
        if (!argument.empty())
            argv.push_back(argument);
        return start(argv, "probe-" + command + std::to_string(processes.size()));
    }
    bool port_open(const std::string& port) { return run_cli(dir, daemon, {"exists", port}).status == 0; }
    /// `plexus write /writer/N` connected to `port`: lines sent to it reach `port`.
    std::unique_ptr<CliWriter> writer_into(const std::string& port) {
        const std::string own = "/writer/" + std::to_string(++writers);
        auto writer = std::make_unique<CliWriter>(dir, daemon, own, "writer" + std::to_string(writers));
        EXPECT_TRUE(eventually([&] { return port_open(own); })) << writer->process().err();
        const auto connected = run_cli(dir, daemon, {"connect", own, port, "local"});
        EXPECT_EQ(connected.status, 0) << connected.err;
        return writer;
    }
    int writers = 0;
    nlohmann::json port_stats(const std::string& port) {
        const auto result = run_cli(dir, daemon, {"stats", port, "--json"});
        const auto stats = nlohmann::json::parse(result.out, nullptr, false);
        if (stats.is_discarded())
            return {};
        for (const auto& entry : stats.value("ports", nlohmann::json::array())) {
            if (entry.value("name", "") == port)
                return entry;
        }
        return {};
    }
};

TEST(BridgeRos2_test, AStringFromADdsPublisherReachesPlexusAndAPlexusWriteReachesADdsSubscriber) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    auto& bridge = ros.bridge({"--in", "/chatter=/ros/chatter:std_msgs/msg/String", "--out",
                               "/to_ros=/from_plexus:std_msgs/msg/String"});
    ASSERT_TRUE(eventually([&] { return ros.port_open("/ros/chatter") && ros.port_open("/to_ros"); }))
        << bridge.err();
    // `plexus read PORT SRC` opens PORT and connects SRC, the bridge's port, to it.
    auto reader = start_cli(ros.dir, ros.daemon, {"read", "/chatter", "/ros/chatter"}, "read-chatter");
    ros.probe("pub-string", "/chatter", "hello {n}");
    EXPECT_TRUE(eventually([&] { return reader->out().find("hello") != std::string::npos; }))
        << "plexus read saw: " << reader->out() << "\nbridge: " << bridge.err();
    // The payload as a Plexus map of the message's fields.
    EXPECT_NE(reader->out().find("\"data\""), std::string::npos) << reader->out();

    auto& subscriber = ros.probe("sub-string", "/from_plexus");
    auto writer = ros.writer_into("/to_ros");
    // Until DDS has matched the bridge's writer with the subscriber, a volatile sample reaches
    // nobody: write until one arrives.
    EXPECT_TRUE(eventually([&] {
        writer->send("{\"data\": \"from plexus\"}\n");
        return subscriber.out().find("from plexus") != std::string::npos;
    })) << "the DDS subscriber saw: "
        << subscriber.out() << "\nbridge: " << bridge.err();
    EXPECT_TRUE(eventually([&] { return ros.port_stats("/to_ros")["reported"].value("passed", 0) >= 1; }))
        << ros.port_stats("/to_ros").dump();
}

TEST(BridgeRos2_test, ThePublisherAndTheDaemonMayGoAwayAndComeBack) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    auto& bridge = ros.bridge({"--in", "/chatter=/ros/chatter:std_msgs/msg/String"});
    ASSERT_TRUE(eventually([&] { return ros.port_open("/ros/chatter"); })) << bridge.out();
    auto& first = ros.probe("pub-string", "/chatter", "first {n}");
    auto reader = start_cli(ros.dir, ros.daemon, {"read", "/chatter", "/ros/chatter"}, "read-1");
    ASSERT_TRUE(eventually([&] { return reader->out().find("first") != std::string::npos; })) << bridge.out();

    first.signal(SIGKILL);  // the ROS 2 node dies; another one starts
    ros.probe("pub-string", "/chatter", "second {n}");
    EXPECT_TRUE(eventually([&] { return reader->out().find("second") != std::string::npos; }, 30s))
        << reader->out() << "\nbridge: " << bridge.out();

    ros.daemon.process().signal(SIGKILL);  // and the daemon too, restarted by its supervisor
    ASSERT_TRUE(ros.daemon.process().wait(10s).has_value());
    ros.daemon.start_again();
    ASSERT_TRUE(eventually([&] { return ros.port_open("/ros/chatter"); }, 30s))
        << "the bridge did not open its port again: " << bridge.out();
    auto again = start_cli(ros.dir, ros.daemon, {"read", "/chatter2", "/ros/chatter"}, "read-2");
    EXPECT_TRUE(eventually([&] { return again->out().find("second") != std::string::npos; }, 30s))
        << again->out() << "\nbridge: " << bridge.out();
    EXPECT_TRUE(bridge.running());
}

TEST(BridgeRos2_test, WhatCannotBeConvertedIsCountedOnThePortAndTheBridgeGoesOn) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    auto& bridge = ros.bridge({"--out", "/to_ros=/from_plexus:geometry_msgs/msg/Twist"});
    ASSERT_TRUE(eventually([&] { return ros.port_open("/to_ros"); })) << bridge.err();
    auto& subscriber = ros.probe("sub-twist", "/from_plexus");
    auto writer = ros.writer_into("/to_ros");
    writer->send("{\"linear\": {\"x\": \"fast\"}}\n{\"linear\": {\"q\": 1}}\n\"just text\"\n");
    EXPECT_TRUE(eventually([&] {
        return ros.port_stats("/to_ros")["reported"].value("not_converted", 0) == 3;
    })) << ros.port_stats("/to_ros").dump();
    // Logged once for the kind, naming the field.
    EXPECT_NE(bridge.out().find("linear.x: expected a number, not a text"), std::string::npos)
        << bridge.out();
    EXPECT_EQ(bridge.out().find("linear.q"), std::string::npos) << "a second failure of a kind is not logged";
    EXPECT_TRUE(eventually([&] {
        writer->send("{\"linear\": {\"x\": 0.5}}\n");
        return subscriber.out().find("0.5 0") != std::string::npos;
    })) << subscriber.out();
}

TEST(BridgeRos2_test, AnUnknownTypeIsRefusedAtStartNamingTheKnownOnes) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    auto& bridge = ros.bridge({"--in", "/odom=/odom:nav_msgs/msg/Odometry"});
    const auto status = bridge.wait(30s);
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(*status, 2);
    EXPECT_NE(bridge.err().find("unknown ROS 2 type 'nav_msgs/msg/Odometry'"), std::string::npos)
        << bridge.err();
    EXPECT_NE(bridge.err().find("geometry_msgs/msg/Twist"), std::string::npos) << bridge.err();
}

/// The last `count` lines of `process`'s output after the first `skip`, once there are that many.
std::vector<std::string> lines_after(Process& process, std::size_t skip, std::size_t count) {
    const auto lines = lines_of(process.out());
    if (lines.size() < skip + count)
        return {};
    return {lines.end() - static_cast<std::ptrdiff_t>(count), lines.end()};
}

bool all_are(const std::vector<std::string>& lines, const std::string& value) {
    if (lines.empty())
        return false;
    for (const auto& line : lines) {
        if (line != value)
            return false;
    }
    return true;
}

/// Waits until the last lines `base` printed are all `value` (the arbitration has switched to that
/// source), then checks that the next 40 (0.8 s of a 50 Hz teleop) are too: only that source.
void settles_on(Process& base, const std::string& value) {
    std::size_t mark = 0;
    EXPECT_TRUE(eventually(
        [&] {
            const auto lines = lines_of(base.out());
            if (lines.size() >= 5 && all_are({lines.end() - 5, lines.end()}, value)) {
                mark = lines.size();
                return true;
            }
            return false;
        },
        30s))
        << "the base never settled on " << value << "; it saw:\n"
        << base.out();
    std::vector<std::string> next;
    EXPECT_TRUE(eventually([&] { return !(next = lines_after(base, mark, 40)).empty(); }, 30s));
    EXPECT_TRUE(all_are(next, value)) << "another source reached the base:\n" << base.out();
}

TEST(BridgeRos2_test, TwoTeleopNodesArbitratedByEventsReachCmdVelOneAtATime) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    const std::string twist = ":geometry_msgs/msg/Twist";
    auto& bridge =
        ros.bridge({"--in", "/joy/cmd_vel=/joy/cmd_vel" + twist, "--in", "/nav/cmd_vel=/nav/cmd_vel" + twist,
                    "--out", "/robot/cmd_vel=/cmd_vel" + twist});
    ASSERT_TRUE(eventually([&] {
        return ros.port_open("/joy/cmd_vel") && ros.port_open("/nav/cmd_vel") &&
               ros.port_open("/robot/cmd_vel");
    })) << bridge.err();
    // The joystick's deadman button, a Plexus port of its own: while it is held, the joystick drives.
    CliWriter deadman(ros.dir, ros.daemon, "/joy/deadman", "deadman");
    deadman.send("{\"held\": false}\n");
    ASSERT_TRUE(eventually([&] { return ros.port_open("/joy/deadman"); }));
    const auto connect = [&](const std::string& source, const std::string& carrier) {
        const auto result = run_cli(ros.dir, ros.daemon, {"connect", source, "/robot/cmd_vel", carrier});
        ASSERT_EQ(result.status, 0) << result.err;
    };
    connect(
        "/joy/deadman",
        "local+recv.portmonitor+type.lua+file.when+field.held+equals.true+event.joy_held+lifetime.600+aux");
    connect("/joy/cmd_vel", "local+recv.portmonitor+constraint.joy_held");
    connect("/nav/cmd_vel", "local+recv.portmonitor+constraint.not joy_held");

    // Two teleop nodes, as `ros2 run ... --ros-args -r cmd_vel:=/joy/cmd_vel` would start them, and
    // the robot's base listening on /cmd_vel.
    ros.probe("pub-twist", "/joy/cmd_vel", "1");
    ros.probe("pub-twist", "/nav/cmd_vel", "2");
    auto& base = ros.probe("sub-twist", "/cmd_vel");

    settles_on(base, "2 -2");  // the navigation stack drives
    deadman.send("{\"held\": true}\n");
    settles_on(base, "1 -1");  // the joystick takes over
    deadman.send("{\"held\": false}\n");
    settles_on(base, "2 -2");  // and gives it back
}

TEST(BridgeRos2_test, TheShippedTeleopApplicationArbitratesTwoNodesByTheJoysticksEnableButton) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    ros.domain = "0";  // `plexus up` starts the bridge with the environment of the CLI: no ROS_DOMAIN_ID
    const std::string app = std::string(PLEXUS_SOURCE_DIR) + "/configs/apps/ros2_teleop.json";
    // The enable event outlives the button's last message by 2 s instead of the file's 0.5: a
    // machine that stalls a moment under a sanitizer must not look like a released button.
    ::setenv("ENABLE_LIFETIME", "2", 1);
    const auto up = run_cli(ros.dir, ros.daemon, {"up", app});
    ASSERT_EQ(up.status, 0) << up.out << up.err;
    struct Down {
        RosHost& ros;
        std::string app;
        ~Down() { run_cli(ros.dir, ros.daemon, {"down", app}); }
    } down{ros, app};

    ros.probe("pub-twist", "/joy/cmd_vel", "1");
    ros.probe("pub-twist", "/nav/cmd_vel", "2");
    auto& base = ros.probe("sub-twist", "/cmd_vel");
    settles_on(base, "2 -2");
    auto& held = ros.probe("pub-bool", "/joy/enable", "true");  // the button is pressed
    settles_on(base, "1 -1");
    held.signal(SIGKILL);  // released: the event's lifetime ends, navigation drives again
    settles_on(base, "2 -2");
}

std::uint64_t fnv1a_of_pattern(std::size_t bytes) {
    std::uint64_t hash = 1469598103934665603ull;
    for (std::size_t i = 0; i < bytes; ++i) {
        hash ^= static_cast<std::uint8_t>((i * 7 + i / 251) & 0xff);
        hash *= 1099511628211ull;
    }
    return hash;
}

TEST(BridgeRos2_test, ASixMegabyteImageGoesThroughPlexusAndBackByteIdentical) {
    PLEXUS_NEEDS_NETNS();
    RosHost ros;
    const std::string image = ":sensor_msgs/msg/Image";
    auto& bridge =
        ros.bridge({"--in", "/camera=/camera" + image, "--out", "/camera_copy=/camera_copy" + image});
    ASSERT_TRUE(eventually([&] { return ros.port_open("/camera") && ros.port_open("/camera_copy"); }))
        << bridge.err();
    ASSERT_EQ(run_cli(ros.dir, ros.daemon, {"connect", "/camera", "/camera_copy", "local"}).status, 0);
    constexpr std::size_t bytes = 6'000'000;
    auto& copy = ros.probe("sub-image", "/camera_copy");
    ros.probe("pub-image", "/camera", std::to_string(bytes));
    char expected[128];
    std::snprintf(expected, sizeof expected, "2000 1000 rgb8 %zu %016llx", bytes,
                  static_cast<unsigned long long>(fnv1a_of_pattern(bytes)));
    EXPECT_TRUE(eventually([&] { return copy.out().find(expected) != std::string::npos; }, 60s))
        << "expected " << expected << ", the DDS subscriber saw:\n"
        << copy.out() << "\nbridge: " << bridge.err();
    const auto lines = lines_of(copy.out());
    for (const auto& line : lines)
        EXPECT_EQ(line, expected) << "every copy is the image, byte for byte";
}

}  // namespace bridge_ros2_test
}  // namespace plexus::test
