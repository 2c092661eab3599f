// plexus-sim-hand: a hand controller. Reads {"close": bool} and writes it on. Knows nothing of the task.
#include <CLI/CLI.hpp>

#include "forwarder.hpp"

int main(int argc, char** argv) {
    std::string in = "/hand/in";
    std::string out = "/hand/out";
    CLI::App app{"plexus-sim-hand: passes hand commands {\"close\": bool} on."};
    app.add_option("--in", in, "input port: {\"close\": bool}")->capture_default_str();
    app.add_option("--out", out, "output port: {\"close\": bool}")->capture_default_str();
    CLI11_PARSE(app, argc, argv);
    using namespace plexus::sim;
    return run_forwarder("plexus-sim-hand", in, out,
                         [](const plexus::Value& message) -> Parsed<plexus::Value> {
                             const auto close = parse_hand_command(message);
                             if (!close)
                                 return {std::nullopt, close.error};
                             return {plexus::Value{{"close", *close.value}}, {}};
                         });
}
