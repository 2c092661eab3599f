// Each bad case of an application file, and what `plexus check` says about it: the message names
// the file, the entry and the field.
#include <gtest/gtest.h>

#include "app_test_files.hpp"

namespace plexus::app {
namespace {

using test::AppDir;
using test::problems_of;
using test::variables;

/// A file with two plain components and a good connection, plus `connections` added after it.
std::string app_text(const std::string& connections, const std::string& components = "") {
    return R"({"name": "demo", "scripts": ["monitors"],
  "components": [
    {"name": "sensor", "command": "/bin/true", "ports": ["/sensor/out"]},
    {"name": "sink", "command": "/bin/true", "args": ["--seed", "${SEED:-1}"], "ports": ["/sink/in"]})" +
           components + R"(
  ],
  "connections": [
    {"source": "/sensor/out", "destination": "/sink/in", "carrier": "tcp"})" +
           connections + R"(
  ]})";
}

/// The only problem, after checking that there is exactly one and that it names `parts`.
void expect_one_problem(const std::vector<std::string>& problems, const std::vector<std::string>& parts) {
    ASSERT_EQ(problems.size(), 1u) << ::testing::PrintToString(problems);
    for (const auto& part : parts)
        EXPECT_NE(problems[0].find(part), std::string::npos) << "'" << part << "' not in: " << problems[0];
}

TEST(AppCheck_test, AcceptsAGoodFileAndReadsItsFields) {
    AppDir dir;
    dir.write("monitors/when.lua", "PortMonitor = {}");
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/a/out", "destination": "/sink/in", "carrier": "tcp+recv.portmonitor+type.lua+file.when+constraint.e_a", "persist": false},
    {"source": "/b/out", "destination": "/sink/in", "carrier": "tcp+recv.portmonitor+constraint.not e_a"})"));
    // The first connection into /sink/in has no constraint: it overlaps the others. Give it one.
    auto loaded = load_app(path, variables({{"SEED", "9"}}));
    ASSERT_TRUE(loaded.app);
    EXPECT_TRUE(loaded.problems.empty()) << ::testing::PrintToString(loaded.problems);
    const App& app = *loaded.app;
    EXPECT_EQ(app.name, "demo");
    ASSERT_EQ(app.components.size(), 2u);
    EXPECT_EQ(app.components[1].args, (std::vector<std::string>{"--seed", "9"}));
    ASSERT_EQ(app.connections.size(), 3u);
    EXPECT_TRUE(app.connections[0].persist);
    EXPECT_FALSE(app.connections[1].persist);
    EXPECT_EQ(app.scripts, (std::vector<std::string>{dir.path() + "/monitors"}));
    const auto report = check_app(app);
    // /sensor/out -> /sink/in has no constraint, so it can deliver alongside both others.
    ASSERT_EQ(report.problems.size(), 2u) << ::testing::PrintToString(report.problems);
    EXPECT_NE(report.problems[0].find("connections[0] /sensor/out -> /sink/in"), std::string::npos);
}

TEST(AppCheck_test, AcceptsPlainFanInAndStimulation) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/a/out", "destination": "/sink/in"},
    {"source": "/face/out", "destination": "/gaze/in", "carrier": "tcp+recv.priority+tc.0.5"},
    {"source": "/obj/out", "destination": "/gaze/in", "carrier": "tcp+recv.priority+tc.0.5+ex./face/out:-1"})"));
    EXPECT_TRUE(problems_of(path).empty()) << ::testing::PrintToString(problems_of(path));
}

TEST(AppCheck_test, NamesAnUnknownField) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/a/out", "destination": "/b/in", "persistent": true})"));
    expect_one_problem(problems_of(path),
                       {path, "connections[1] /a/out -> /b/in", "unknown field \"persistent\"", "persist"});
}

TEST(AppCheck_test, NamesAnUnknownComponentFieldAndTopLevelField) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text("", R"(,
    {"name": "world", "command": "/bin/true", "nodes": "x"})"));
    expect_one_problem(problems_of(path), {path, "components[2] \"world\"", "unknown field \"nodes\""});
    const auto top = dir.write("top.json", R"({"name": "x", "componets": []})");
    expect_one_problem(problems_of(top), {top, "unknown field \"componets\""});
}

TEST(AppCheck_test, NamesAMissingScript) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/a/out", "destination": "/b/in", "carrier": "tcp+recv.portmonitor+type.lua+file.nothere"})"));
    expect_one_problem(problems_of(path), {path, "connections[1] /a/out -> /b/in", "\"carrier\"",
                                           "file.nothere", "nothere.lua", dir.path() + "/monitors"});
}

TEST(AppCheck_test, NamesAPortClaimedTwiceAndAConnectionTwice) {
    AppDir dir;
    const auto claimed = dir.write("claimed.json", app_text("", R"(,
    {"name": "other", "command": "/bin/true", "ports": ["/sensor/out"]})"));
    expect_one_problem(problems_of(claimed), {claimed, "components[2] \"other\"", "\"ports\"", "/sensor/out",
                                              "components[0] \"sensor\""});
    const auto twice = dir.write("twice.json", app_text(R"(,
    {"source": "/sensor/out", "destination": "/sink/in", "carrier": "udp"})"));
    expect_one_problem(problems_of(twice), {twice, "connections[1] /sensor/out -> /sink/in",
                                            "same connection as connections[0]"});
}

TEST(AppCheck_test, NamesSingularWeights) {
    AppDir dir;
    // Two connections exciting each other with weight 1: with both active, I - A^T is singular.
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/face/out", "destination": "/gaze/in", "carrier": "tcp+recv.priority+ex./obj/out:1"},
    {"source": "/obj/out", "destination": "/gaze/in", "carrier": "tcp+recv.priority+ex./face/out:1"})"));
    expect_one_problem(problems_of(path),
                       {path, "connections into /gaze/in", "connections[2] /obj/out -> /gaze/in",
                        "\"carrier\"", "inconsistent weights", "/face/out, /obj/out"});
}

TEST(AppCheck_test, NamesOverlappingConstraints) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text(R"(,
    {"source": "/c1/out", "destination": "/head/in", "carrier": "tcp+recv.portmonitor+constraint.e_template_ok"},
    {"source": "/c2/out", "destination": "/head/in", "carrier": "tcp+recv.portmonitor+constraint.e_particle_ok"})"));
    expect_one_problem(
        problems_of(path),
        {path, "connections into /head/in", "connections[1] /c1/out -> /head/in",
         "connections[2] /c2/out -> /head/in", "e_template_ok present", "e_particle_ok present"});
    // The paper's fix: C1 only while the particle filter has nothing.
    const auto fixed = dir.write("fixed.json", app_text(R"(,
    {"source": "/c1/out", "destination": "/head/in", "carrier": "tcp+recv.portmonitor+constraint.e_template_ok and not e_particle_ok"},
    {"source": "/c2/out", "destination": "/head/in", "carrier": "tcp+recv.portmonitor+constraint.e_particle_ok"})"));
    EXPECT_TRUE(problems_of(fixed).empty()) << ::testing::PrintToString(problems_of(fixed));
}

TEST(AppCheck_test, NamesAnUnsetVariable) {
    AppDir dir;
    const auto path = dir.write("app.json", app_text("", R"(,
    {"name": "world", "command": "/bin/true", "args": ["--speed", "${SPEED}"]})"));
    expect_one_problem(problems_of(path),
                       {path, "components[2] \"world\"", "\"args[1]\"", "variable SPEED is not set"});
    EXPECT_TRUE(problems_of(path, variables({{"SPEED", "3"}})).empty());
}

TEST(AppCheck_test, NamesABadCarrier) {
    AppDir dir;
    const auto unknown = dir.write("unknown.json", app_text(R"(,
    {"source": "/a/out", "destination": "/b/in", "carrier": "tcp+recv.bogus"})"));
    expect_one_problem(problems_of(unknown),
                       {unknown, "connections[1] /a/out -> /b/in", "\"carrier\"", "recv.bogus"});
    const auto constraint = dir.write("constraint.json", app_text(R"(,
    {"source": "/a/out", "destination": "/b/in", "carrier": "tcp+recv.portmonitor+constraint.e_a and"})"));
    expect_one_problem(problems_of(constraint),
                       {constraint, "connections[1] /a/out -> /b/in", "\"carrier\"", "position"});
    const auto priority = dir.write("priority.json", app_text(R"(,
    {"source": "/a/out", "destination": "/b/in", "carrier": "tcp+recv.priority+tc.fast"})"));
    expect_one_problem(problems_of(priority),
                       {priority, "connections[1] /a/out -> /b/in", "\"carrier\"", "tc"});
}

TEST(AppCheck_test, NamesWrongTypesMissingFieldsAndBadPorts) {
    AppDir dir;
    const auto path = dir.write("app.json", R"({"name": "demo",
  "components": [{"command": "x"}, {"name": "b", "command": "x", "ports": ["no-slash"]}],
  "connections": [{"source": "/a/out", "destination": "/b/in", "persist": "yes"}]})");
    const auto problems = problems_of(path);
    ASSERT_EQ(problems.size(), 3u) << ::testing::PrintToString(problems);
    EXPECT_NE(problems[0].find("components[0]: missing field \"name\""), std::string::npos) << problems[0];
    EXPECT_NE(problems[1].find("components[1] \"b\": \"ports[0]\""), std::string::npos) << problems[1];
    EXPECT_NE(problems[2].find("connections[0] /a/out -> /b/in: \"persist\": expected true or false"),
              std::string::npos)
        << problems[2];
}

TEST(AppCheck_test, NamesBadJson) {
    AppDir dir;
    const auto path = dir.write("app.json", "{\"name\": \"demo\",\n \"components\": [}");
    expect_one_problem(problems_of(path), {path, "not valid JSON", "line 2"});
}

// Found by tests/fuzz/app_file_fuzz.cpp: a number too large for a double is nlohmann's
// out_of_range, not a parse_error, and escaped parse_app instead of becoming a problem.
TEST(AppCheck_test, NamesANumberTooLargeAsBadJson) {
    const auto loaded = parse_app("4E4448hh-${S:c]}", "/apps/app.json", variables({}));
    EXPECT_FALSE(loaded.app);
    expect_one_problem(loaded.problems, {"/apps/app.json", "not valid JSON", "number overflow"});
}

TEST(AppCheck_test, ABridgeIsAComponentThatWaitsForThePortsItsMappingsName) {
    const auto loaded = parse_app(R"({"name": "robot", "bridges": [
      {"name": "ros", "kind": "ros2", "domain": 3,
       "in": ["/joy/cmd_vel=/ros/joy:geometry_msgs/msg/Twist"], "out": ["/robot/cmd_vel=/cmd_vel:geometry_msgs/msg/Twist"]},
      {"name": "devices", "kind": "mqtt", "broker": "${BROKER:-localhost:1883}", "in": ["sensors/+/temp=/mqtt/temp"],
       "args": ["--qos", "0"]}]})",
                                  "/apps/robot.json", variables({}));
    ASSERT_TRUE(loaded.app);
    EXPECT_TRUE(loaded.problems.empty()) << ::testing::PrintToString(loaded.problems);
    ASSERT_EQ(loaded.app->components.size(), 2u);
    const auto& ros = loaded.app->components[0];
    EXPECT_EQ(ros.command, "plexus-bridge");
    EXPECT_EQ(ros.args, (std::vector<std::string>{"ros2", "--domain", "3", "--in",
                                                  "/joy/cmd_vel=/ros/joy:geometry_msgs/msg/Twist", "--out",
                                                  "/robot/cmd_vel=/cmd_vel:geometry_msgs/msg/Twist"}));
    EXPECT_EQ(ros.ports, (std::vector<std::string>{"/ros/joy", "/robot/cmd_vel"}));
    EXPECT_EQ(ros.label(), "bridges[0] \"ros\"");
    const auto& devices = loaded.app->components[1];
    EXPECT_EQ(devices.args, (std::vector<std::string>{"mqtt", "--broker", "localhost:1883", "--in",
                                                      "sensors/+/temp=/mqtt/temp", "--qos", "0"}));
    EXPECT_EQ(devices.ports, (std::vector<std::string>{"/mqtt/temp"}));
}

TEST(AppCheck_test, NamesWhatIsWrongWithABridge) {
    const auto problems = [](const std::string& bridge) {
        return parse_app(R"({"name": "robot", "bridges": [)" + bridge + "]}", "/apps/robot.json",
                         variables({}))
            .problems;
    };
    expect_one_problem(problems(R"({"name": "b", "kind": "zenoh", "in": ["a=/b"]})"),
                       {"bridges[0]", "\"kind\": expected ros2 or mqtt"});
    expect_one_problem(problems(R"({"name": "b", "kind": "ros2"})"), {"bridges[0]", "nothing to bridge"});
    expect_one_problem(problems(R"({"name": "b", "kind": "ros2", "in": ["/chatter"]})"),
                       {"bridges[0]", "\"in[0]\": expected TOPIC=PORT:TYPE"});
    expect_one_problem(problems(R"({"name": "b", "kind": "mqtt", "domain": 1, "in": ["a=/b"]})"),
                       {"bridges[0]", "\"domain\""});
    expect_one_problem(problems(R"({"name": "b", "kind": "mqtt", "in": ["a=/b"], "qos": 1})"),
                       {"bridges[0]", "unknown field \"qos\""});
    expect_one_problem(problems(R"({"kind": "mqtt", "in": ["a=/b"]})"),
                       {"bridges[0]", "missing field \"name\""});
}

TEST(AppCheck_test, ReadsTheShippedFetchApplication) {
    // configs/apps/fetch.json is another engineer's; reading it must not fail on its schema.
    const std::string fetch = std::string(PLEXUS_SOURCE_DIR) + "/configs/apps/fetch.json";
    if (!std::filesystem::exists(fetch))
        GTEST_SKIP() << "no " << fetch;
    EXPECT_TRUE(problems_of(fetch).empty()) << ::testing::PrintToString(problems_of(fetch));
}

TEST(AppCheck_test, ReadsTheShippedRos2TeleopApplication) {
    const std::string teleop = std::string(PLEXUS_SOURCE_DIR) + "/configs/apps/ros2_teleop.json";
    auto loaded = load_app(teleop, variables({}));
    ASSERT_TRUE(loaded.app);
    EXPECT_TRUE(loaded.problems.empty()) << ::testing::PrintToString(loaded.problems);
    // Its arbitration: the two teleops' constraints are complementary.
    const auto report = check_app(*loaded.app);
    for (const auto& problem : report.problems)
        EXPECT_EQ(problem.find("can both be true"), std::string::npos) << problem;
}

}  // namespace
}  // namespace plexus::app
