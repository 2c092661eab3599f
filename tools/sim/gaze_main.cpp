// plexus-sim-gaze: a gaze controller. Reads points to look at ({"x","y"}, or {"angle"} as is) and
// writes head targets {"angle": atan2(y, x)}. Knows nothing of the task.
#include <cmath>
#include <variant>

#include <CLI/CLI.hpp>

#include "forwarder.hpp"

int main(int argc, char** argv) {
    std::string in = "/gaze/in";
    std::string out = "/gaze/out";
    CLI::App app{"plexus-sim-gaze: turns points to look at into gaze angles {\"angle\": atan2(y, x)}."};
    app.add_option("--in", in, "input port: {\"x\",\"y\"} or {\"angle\"}")->capture_default_str();
    app.add_option("--out", out, "output port: {\"angle\"}")->capture_default_str();
    CLI11_PARSE(app, argc, argv);
    using namespace plexus::sim;
    return run_forwarder(
        "plexus-sim-gaze", in, out, [](const plexus::Value& message) -> Parsed<plexus::Value> {
            const auto target = parse_gaze_target(message);
            if (!target)
                return {std::nullopt, target.error};
            const double angle =
                std::holds_alternative<double>(*target.value)
                    ? std::get<double>(*target.value)
                    : std::atan2(std::get<Point>(*target.value).y, std::get<Point>(*target.value).x);
            return {plexus::Value{{"angle", angle}}, {}};
        });
}
