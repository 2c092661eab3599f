// plexus-sim-arm: an arm controller. Reads points to reach and writes them on as arm targets
// {"x","y"} (any other keys, like a detector's certainty, are left behind). Knows nothing of the task.
#include <CLI/CLI.hpp>

#include "forwarder.hpp"

int main(int argc, char** argv) {
    std::string in = "/arm/in";
    std::string out = "/arm/out";
    CLI::App app{"plexus-sim-arm: passes the latest point to reach on as an arm target {\"x\",\"y\"}."};
    app.add_option("--in", in, "input port: {\"x\",\"y\"}")->capture_default_str();
    app.add_option("--out", out, "output port: {\"x\",\"y\"}")->capture_default_str();
    CLI11_PARSE(app, argc, argv);
    using namespace plexus::sim;
    return run_forwarder("plexus-sim-arm", in, out,
                         [](const plexus::Value& message) -> Parsed<plexus::Value> {
                             const auto point = parse_point(message);
                             if (!point)
                                 return {std::nullopt, point.error};
                             return {plexus::Value{{"x", point.value->x}, {"y", point.value->y}}, {}};
                         });
}
