#pragma once
// The simulated world of the fetch-and-carry robot: a robot at the origin facing +x, a table with an
// object on it, a person walking around the robot, a head that turns, an arm that reaches and a hand
// that grasps. Physics and the phase judgement only: no I/O, no clock, no messages. The program
// (world_main.cpp) steps it with a fixed dt and feeds it commands; tests do the same by hand.
//
// Threading: a plain value-like object, used by one thread.
#include <cstdint>
#include <optional>
#include <random>
#include <string_view>

namespace plexus::sim {

/// A point or a vector in the world, in metres.
struct Point {
    double x = 0;
    double y = 0;
};

double distance(Point a, Point b);

/// The world's fixed rules (the numbers of tools/sim/README.md), in one place.
struct WorldRules {
    double table_x_min = 0.3, table_x_max = 0.6;
    double table_y_min = -0.4, table_y_max = 0.4;
    double person_radius = 1.0;
    double person_angle_limit = 1.2;   ///< phi in [-limit, limit]
    double person_max_speed = 0.15;    ///< rad/s
    double person_acceleration = 0.3;  ///< rad/s^2, the largest random change of its angular speed
    double gaze_limit = 1.5;           ///< g in [-limit, limit]
    double gaze_speed = 2.0;           ///< rad/s
    double field_of_view = 0.3;        ///< half-angle, rad
    Point hand_home{0.15, 0.0};
    double arm_speed = 0.5;            ///< m/s
    double arm_reach = 0.75;           ///< m from the origin
    double hand_transition = 0.3;      ///< s to close or to open
    double grasp_distance = 0.04;      ///< m between hand and object to grasp it
    double release_distance = 0.35;    ///< m between hand and person to hand the object over
    double respawn_delay = 1.0;        ///< s after a delivery until a new object appears
    double hide_duration = 3.0;        ///< s
    double drop_scatter = 0.1;         ///< m, the largest random offset of a dropped object
    double reach_tolerance = 0.1;      ///< m between arm target and object for "reach"
    double approach_tolerance = 0.15;  ///< m between arm target and person for "approach"
};

enum class HandState { open, closing, closed, opening };
std::string_view to_string(HandState state);

/// Where the object is: on the table, in the hand, hidden (on the table, invisible, about to move),
/// or absent (delivered; a new one appears after the respawn delay).
enum class ObjectState { on_table, held, hidden, absent };
std::string_view to_string(ObjectState state);

/// The task phase, judged from the world's state alone.
enum class Phase { search_object, reach, grasp, search_person, approach, release };
std::string_view to_string(Phase phase);

/// Whether a disturbance did something, and if not, why (for the log).
struct Outcome {
    bool applied = true;
    std::string_view reason;  ///< empty when applied
};

class WorldModel {
public:
    explicit WorldModel(std::uint64_t seed = 1, WorldRules rules = {});

    /// Advances the world by dt sim seconds.
    void step(double dt);

    // Commands: the latest of each kind wins.
    /// Look toward this angle (clamped to the gaze limits).
    void set_gaze_target(double angle);
    /// Look at this point.
    void set_gaze_target(Point point);
    /// Move the hand toward this point (clamped to the arm's reach).
    void set_arm_target(Point point);
    /// Close (true) or open (false) the hand. The latest wish is remembered: it starts a transition
    /// now if the hand rests in the other state, or as soon as a running transition completes.
    void command_hand(bool close);

    // Disturbances.
    /// A held object falls onto the table near the hand.
    Outcome drop();
    /// An object on the table disappears for a while, then reappears elsewhere on the table.
    Outcome hide();
    Outcome person_away();
    /// The person comes back at a random angle.
    Outcome person_back();

    // Observations.
    double time() const { return time_; }
    double gaze() const { return gaze_; }
    double gaze_target() const { return gaze_target_; }
    Point hand() const { return hand_; }
    Point arm_target() const { return arm_target_; }
    HandState hand_state() const { return hand_state_; }
    ObjectState object_state() const { return object_state_; }
    bool holding() const { return object_state_ == ObjectState::held; }
    /// Where the object is, if it exists and is not hidden.
    std::optional<Point> object() const;
    bool object_visible() const;
    /// 1 at the centre of the field of view, 0.5 at its edge; nullopt when not visible.
    std::optional<double> object_certainty() const;
    /// Where the person is, if present.
    std::optional<Point> person() const;
    double person_angle() const { return person_angle_; }
    bool person_visible() const;
    std::optional<double> hand_to_object() const;
    std::optional<double> hand_to_person() const;
    int deliveries() const { return deliveries_; }
    Phase phase() const;
    const WorldRules& rules() const { return rules_; }

    // For tests: put things where a test needs them.
    void place_object(Point point);
    void place_person(double angle);

private:
    Point random_table_point();
    Point clamp_to_table(Point point) const;
    void walk_person(double dt);
    void turn_head(double dt);
    void move_arm(double dt);
    void advance_hand(double dt);
    void start_hand_transition_if_wanted();
    void complete_closing();
    void complete_opening();
    bool in_field_of_view(Point point) const;

    WorldRules rules_;
    std::mt19937_64 random_;
    double time_ = 0;

    Point object_;
    ObjectState object_state_ = ObjectState::on_table;
    double object_returns_at_ = 0;  ///< when a hidden or absent object (re)appears
    int deliveries_ = 0;
    std::optional<double> last_delivery_;

    bool person_present_ = true;
    double person_angle_ = 0;
    double person_speed_ = 0;  ///< rad/s

    double gaze_ = 0;
    double gaze_target_ = 0;

    Point hand_;
    Point arm_target_;
    HandState hand_state_ = HandState::open;
    bool want_closed_ = false;
    double transition_left_ = 0;
};

}  // namespace plexus::sim
