#include "world_messages.hpp"

#include <cmath>

namespace plexus::sim {

namespace {

/// The finite number under `key`, if there is one.
std::optional<double> number_at(const Json& message, const char* key) {
    const auto found = message.find(key);
    if (found == message.end() || !found->is_number())
        return std::nullopt;
    const double value = found->get<double>();
    if (!std::isfinite(value))
        return std::nullopt;
    return value;
}

Json optional_number(std::optional<double> value) {
    return value ? Json(*value) : Json(nullptr);
}

}  // namespace

Parsed<Point> parse_point(const Json& message) {
    if (!message.is_object())
        return {std::nullopt, "expected a map {\"x\": number, \"y\": number}, got " + message.dump()};
    const auto x = number_at(message, "x");
    const auto y = number_at(message, "y");
    if (!x || !y)
        return {std::nullopt, "expected finite numbers \"x\" and \"y\", got " + message.dump()};
    return {Point{*x, *y}, {}};
}

Parsed<std::variant<double, Point>> parse_gaze_target(const Json& message) {
    if (message.is_object() && message.contains("angle")) {
        if (const auto angle = number_at(message, "angle"))
            return {*angle, {}};
        return {std::nullopt, "expected a finite number \"angle\", got " + message.dump()};
    }
    auto point = parse_point(message);
    if (!point)
        return {std::nullopt,
                "expected {\"angle\": number} or {\"x\": number, \"y\": number}, got " + message.dump()};
    return {*point.value, {}};
}

Parsed<bool> parse_hand_command(const Json& message) {
    if (message.is_object()) {
        const auto found = message.find("close");
        if (found != message.end() && found->is_boolean())
            return {found->get<bool>(), {}};
    }
    return {std::nullopt, "expected {\"close\": true|false}, got " + message.dump()};
}

Parsed<Disturbance> parse_disturbance(const Json& message) {
    if (message.is_object() && message.size() == 1) {
        if (message.value("drop", Json()) == Json(true))
            return {Disturbance::drop, {}};
        if (message.value("hide", Json()) == Json(true))
            return {Disturbance::hide, {}};
        if (message.value("person", Json()) == Json("away"))
            return {Disturbance::person_away, {}};
        if (message.value("person", Json()) == Json("back"))
            return {Disturbance::person_back, {}};
    }
    return {
        std::nullopt,
        "expected one of {\"drop\": true}, {\"hide\": true}, {\"person\": \"away\"}, {\"person\": \"back\"}, "
        "got " +
            message.dump()};
}

Outcome apply(WorldModel& world, Disturbance disturbance) {
    switch (disturbance) {
        case Disturbance::drop:
            return world.drop();
        case Disturbance::hide:
            return world.hide();
        case Disturbance::person_away:
            return world.person_away();
        case Disturbance::person_back:
            return world.person_back();
    }
    return {false, "unknown disturbance"};
}

std::optional<Json> object_message(const WorldModel& world) {
    const auto certainty = world.object_certainty();
    if (!certainty)
        return std::nullopt;
    const Point at = *world.object();
    return Json{{"x", at.x}, {"y", at.y}, {"certainty", *certainty}};
}

std::optional<Json> person_message(const WorldModel& world) {
    if (!world.person_visible())
        return std::nullopt;
    const Point at = *world.person();
    return Json{{"x", at.x}, {"y", at.y}};
}

Json touch_message(const WorldModel& world) {
    return Json{{"held", world.holding()}};
}

Json proximity_message(const WorldModel& world) {
    return Json{{"object", optional_number(world.hand_to_object())},
                {"person", optional_number(world.hand_to_person())}};
}

Json head_message(const WorldModel& world) {
    return Json{{"gaze", world.gaze()}};
}

Json arm_message(const WorldModel& world) {
    return Json{{"x", world.hand().x}, {"y", world.hand().y}};
}

Json hand_message(const WorldModel& world) {
    return Json{{"state", std::string(to_string(world.hand_state()))}, {"holding", world.holding()}};
}

Json phase_message(const WorldModel& world) {
    return Json{{"phase", std::string(to_string(world.phase()))},
                // Microseconds: sim time is a sum of dt steps, whose rounding noise
                // (7.279999999999933) says nothing.
                {"t", std::round(world.time() * 1e6) / 1e6},
                {"deliveries", world.deliveries()}};
}

}  // namespace plexus::sim
