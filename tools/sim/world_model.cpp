#include "world_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace plexus::sim {

namespace {

// Transitions are counted down by dt; a fixed dt rarely divides 0.3 exactly in floating point, and
// without this slack a transition of 15 steps of 0.02 s would take a 16th.
constexpr double time_slack = 1e-9;

/// a - b as an angle in (-pi, pi].
double angle_difference(double a, double b) {
    return std::remainder(a - b, 2 * std::numbers::pi);
}

/// Moves `from` toward `to` by at most `step`.
double approach(double from, double to, double step) {
    return from + std::clamp(to - from, -step, step);
}

}  // namespace

double distance(Point a, Point b) {
    return std::hypot(a.x - b.x, a.y - b.y);
}

std::string_view to_string(HandState state) {
    switch (state) {
        case HandState::open:
            return "open";
        case HandState::closing:
            return "closing";
        case HandState::closed:
            return "closed";
        case HandState::opening:
            return "opening";
    }
    return "?";
}

std::string_view to_string(ObjectState state) {
    switch (state) {
        case ObjectState::on_table:
            return "on_table";
        case ObjectState::held:
            return "held";
        case ObjectState::hidden:
            return "hidden";
        case ObjectState::absent:
            return "absent";
    }
    return "?";
}

std::string_view to_string(Phase phase) {
    switch (phase) {
        case Phase::search_object:
            return "search_object";
        case Phase::reach:
            return "reach";
        case Phase::grasp:
            return "grasp";
        case Phase::search_person:
            return "search_person";
        case Phase::approach:
            return "approach";
        case Phase::release:
            return "release";
    }
    return "?";
}

WorldModel::WorldModel(std::uint64_t seed, WorldRules rules)
    : rules_(rules), random_(seed), hand_(rules.hand_home), arm_target_(rules.hand_home) {
    // The order of the draws is part of the seed's meaning: object first, then the person.
    object_ = random_table_point();
    person_angle_ = std::uniform_real_distribution<double>(-rules_.person_angle_limit,
                                                           rules_.person_angle_limit)(random_);
}

void WorldModel::step(double dt) {
    if (!(dt > 0))
        return;
    time_ += dt;
    if ((object_state_ == ObjectState::hidden || object_state_ == ObjectState::absent) &&
        time_ + time_slack >= object_returns_at_) {
        object_ = random_table_point();
        object_state_ = ObjectState::on_table;
    }
    walk_person(dt);
    turn_head(dt);
    move_arm(dt);
    advance_hand(dt);
}

void WorldModel::set_gaze_target(double angle) {
    if (std::isfinite(angle))
        gaze_target_ = std::clamp(angle, -rules_.gaze_limit, rules_.gaze_limit);
}

void WorldModel::set_gaze_target(Point point) {
    set_gaze_target(std::atan2(point.y, point.x));
}

void WorldModel::set_arm_target(Point point) {
    if (!std::isfinite(point.x) || !std::isfinite(point.y))
        return;
    const double r = std::hypot(point.x, point.y);
    if (r > rules_.arm_reach)
        point = {point.x * rules_.arm_reach / r, point.y * rules_.arm_reach / r};
    arm_target_ = point;
}

void WorldModel::command_hand(bool close) {
    want_closed_ = close;
    start_hand_transition_if_wanted();
}

Outcome WorldModel::drop() {
    if (object_state_ != ObjectState::held)
        return {false, "nothing is held"};
    // A uniform point of the disc of radius drop_scatter: sqrt of a uniform radius fraction.
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double r = rules_.drop_scatter * std::sqrt(unit(random_));
    const double a = 2 * std::numbers::pi * unit(random_);
    object_ = clamp_to_table({hand_.x + r * std::cos(a), hand_.y + r * std::sin(a)});
    object_state_ = ObjectState::on_table;
    return {};
}

Outcome WorldModel::hide() {
    if (object_state_ == ObjectState::held)
        return {false, "the object is held"};
    if (object_state_ != ObjectState::on_table)
        return {false, "no object is on the table"};
    object_state_ = ObjectState::hidden;
    object_returns_at_ = time_ + rules_.hide_duration;
    return {};
}

Outcome WorldModel::person_away() {
    if (!person_present_)
        return {false, "the person is already away"};
    person_present_ = false;
    return {};
}

Outcome WorldModel::person_back() {
    if (person_present_)
        return {false, "the person is already here"};
    person_present_ = true;
    person_angle_ = std::uniform_real_distribution<double>(-rules_.person_angle_limit,
                                                           rules_.person_angle_limit)(random_);
    person_speed_ = 0;
    return {};
}

std::optional<Point> WorldModel::object() const {
    switch (object_state_) {
        case ObjectState::on_table:
            return object_;
        case ObjectState::held:
            return hand_;
        case ObjectState::hidden:
        case ObjectState::absent:
            return std::nullopt;
    }
    return std::nullopt;
}

bool WorldModel::object_visible() const {
    const auto where = object();
    return where && in_field_of_view(*where);
}

std::optional<double> WorldModel::object_certainty() const {
    const auto where = object();
    if (!where || !in_field_of_view(*where))
        return std::nullopt;
    const double off = std::abs(angle_difference(std::atan2(where->y, where->x), gaze_));
    return 1.0 - 0.5 * off / rules_.field_of_view;
}

std::optional<Point> WorldModel::person() const {
    if (!person_present_)
        return std::nullopt;
    return Point{rules_.person_radius * std::cos(person_angle_),
                 rules_.person_radius * std::sin(person_angle_)};
}

bool WorldModel::person_visible() const {
    return person_present_ && std::abs(angle_difference(person_angle_, gaze_)) <= rules_.field_of_view;
}

std::optional<double> WorldModel::hand_to_object() const {
    const auto where = object();
    if (!where)
        return std::nullopt;
    return distance(hand_, *where);
}

std::optional<double> WorldModel::hand_to_person() const {
    const auto where = person();
    if (!where)
        return std::nullopt;
    return distance(hand_, *where);
}

Phase WorldModel::phase() const {
    if (object_state_ != ObjectState::held) {
        const bool hand_closes = hand_state_ == HandState::closing || hand_state_ == HandState::closed;
        if (object_state_ == ObjectState::on_table && hand_closes &&
            distance(hand_, object_) <= rules_.grasp_distance)
            return Phase::grasp;
        if (object_visible() && distance(arm_target_, *object()) <= rules_.reach_tolerance)
            return Phase::reach;
        if (object_state_ == ObjectState::absent && last_delivery_ &&
            time_ - *last_delivery_ < rules_.respawn_delay)
            return Phase::release;
        return Phase::search_object;
    }
    if (hand_state_ == HandState::opening)
        return Phase::release;
    if (person_present_) {
        // The person stands beyond the arm's reach: the arm can only point at where it would be.
        const Point reachable{rules_.arm_reach * std::cos(person_angle_),
                              rules_.arm_reach * std::sin(person_angle_)};
        if (distance(arm_target_, reachable) <= rules_.approach_tolerance)
            return Phase::approach;
    }
    return Phase::search_person;
}

void WorldModel::place_object(Point point) {
    object_ = point;
    object_state_ = ObjectState::on_table;
}

void WorldModel::place_person(double angle) {
    person_present_ = true;
    person_angle_ = angle;
    person_speed_ = 0;
}

Point WorldModel::random_table_point() {
    const double x = std::uniform_real_distribution<double>(rules_.table_x_min, rules_.table_x_max)(random_);
    const double y = std::uniform_real_distribution<double>(rules_.table_y_min, rules_.table_y_max)(random_);
    return {x, y};
}

Point WorldModel::clamp_to_table(Point point) const {
    return {std::clamp(point.x, rules_.table_x_min, rules_.table_x_max),
            std::clamp(point.y, rules_.table_y_min, rules_.table_y_max)};
}

void WorldModel::walk_person(double dt) {
    if (!person_present_)
        return;
    // A random walk of the angular speed, not of the angle: the person changes direction smoothly
    // instead of jittering, and never walks faster than the limit.
    const double kick = rules_.person_acceleration * dt;
    person_speed_ = std::clamp(person_speed_ + std::uniform_real_distribution<double>(-kick, kick)(random_),
                               -rules_.person_max_speed, rules_.person_max_speed);
    person_angle_ += person_speed_ * dt;
    const double limit = rules_.person_angle_limit;
    if (person_angle_ > limit) {
        person_angle_ = 2 * limit - person_angle_;
        person_speed_ = -person_speed_;
    } else if (person_angle_ < -limit) {
        person_angle_ = -2 * limit - person_angle_;
        person_speed_ = -person_speed_;
    }
}

void WorldModel::turn_head(double dt) {
    gaze_ = approach(gaze_, gaze_target_, rules_.gaze_speed * dt);
}

void WorldModel::move_arm(double dt) {
    const double left = distance(hand_, arm_target_);
    const double step = rules_.arm_speed * dt;
    if (left <= step) {
        hand_ = arm_target_;
    } else {
        hand_.x += (arm_target_.x - hand_.x) * step / left;
        hand_.y += (arm_target_.y - hand_.y) * step / left;
    }
}

void WorldModel::advance_hand(double dt) {
    if (hand_state_ != HandState::closing && hand_state_ != HandState::opening)
        return;
    transition_left_ -= dt;
    if (transition_left_ > time_slack)
        return;
    if (hand_state_ == HandState::closing)
        complete_closing();
    else
        complete_opening();
    // A wish that changed during the transition starts the way back now.
    start_hand_transition_if_wanted();
}

void WorldModel::start_hand_transition_if_wanted() {
    if (hand_state_ == HandState::open && want_closed_) {
        hand_state_ = HandState::closing;
        transition_left_ = rules_.hand_transition;
    } else if (hand_state_ == HandState::closed && !want_closed_) {
        hand_state_ = HandState::opening;
        transition_left_ = rules_.hand_transition;
    }
}

void WorldModel::complete_closing() {
    hand_state_ = HandState::closed;
    if (object_state_ == ObjectState::on_table && distance(hand_, object_) <= rules_.grasp_distance)
        object_state_ = ObjectState::held;
}

void WorldModel::complete_opening() {
    hand_state_ = HandState::open;
    if (object_state_ != ObjectState::held)
        return;
    const auto at = person();
    if (at && distance(hand_, *at) <= rules_.release_distance) {
        ++deliveries_;
        last_delivery_ = time_;
        object_state_ = ObjectState::absent;
        object_returns_at_ = time_ + rules_.respawn_delay;
    } else {
        object_ = clamp_to_table(hand_);
        object_state_ = ObjectState::on_table;
    }
}

bool WorldModel::in_field_of_view(Point point) const {
    return std::abs(angle_difference(std::atan2(point.y, point.x), gaze_)) <= rules_.field_of_view;
}

}  // namespace plexus::sim
