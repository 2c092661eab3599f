#pragma once
// The JSON messages of the simulated world (tools/sim/README.md): reading commands from them and
// writing observations into them. Pure functions: no ports, no clock.
#include <optional>
#include <string>
#include <variant>

#include <nlohmann/json.hpp>

#include "world_model.hpp"

namespace plexus::sim {

using Json = nlohmann::json;

/// What a message asked for, or why it could not be read.
template <typename T>
struct Parsed {
    std::optional<T> value;
    std::string error;  ///< set when value is empty
    explicit operator bool() const { return value.has_value(); }
};

/// {"x": number, "y": number}, both finite. Extra keys are allowed.
Parsed<Point> parse_point(const Json& message);
/// {"angle": number} or a point to look at.
Parsed<std::variant<double, Point>> parse_gaze_target(const Json& message);
/// {"close": bool}.
Parsed<bool> parse_hand_command(const Json& message);

enum class Disturbance { drop, hide, person_away, person_back };
/// {"drop": true}, {"hide": true}, {"person": "away"} or {"person": "back"}.
Parsed<Disturbance> parse_disturbance(const Json& message);

/// Applies a disturbance to the world.
Outcome apply(WorldModel& world, Disturbance disturbance);

/// {"x","y","certainty"} while the object is visible.
std::optional<Json> object_message(const WorldModel& world);
/// {"x","y"} while the person is visible.
std::optional<Json> person_message(const WorldModel& world);
/// {"held": bool}
Json touch_message(const WorldModel& world);
/// {"object": distance or null, "person": distance or null}
Json proximity_message(const WorldModel& world);
/// {"gaze": angle}
Json head_message(const WorldModel& world);
/// {"x","y"} of the hand
Json arm_message(const WorldModel& world);
/// {"state": "open"|"closing"|"closed"|"opening", "holding": bool}
Json hand_message(const WorldModel& world);
/// {"phase", "t", "deliveries"}; the program adds "latency" to "reach".
Json phase_message(const WorldModel& world);

}  // namespace plexus::sim
