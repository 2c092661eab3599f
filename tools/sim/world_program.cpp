#include "world_program.hpp"

#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>
#include <thread>
#include <vector>

#include "input_queue.hpp"
#include "malformed_counter.hpp"
#include "plexus/client.hpp"
#include "stop_signal.hpp"
#include "world_messages.hpp"
#include "world_model.hpp"

namespace plexus::sim {

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* program = "plexus-sim-world";

// If the loop falls this far behind its schedule (a loaded machine), it stops trying to catch up:
// sim time then runs slower than asked instead of in a burst of ticks.
constexpr auto max_lag = std::chrono::milliseconds(500);

/// One input port and the count of what it could not read.
struct Input {
    Input(Client& client, const std::string& name, QueuePolicy policy)
        : queue(client, name, options_for(policy)), malformed(program, name) {}

    /// Command ports keep only the newest messages: a world that fell behind should act on the
    /// latest target, not on a backlog. Disturbances are few and each one matters: none is dropped.
    static PortOptions options_for(QueuePolicy policy) {
        PortOptions options;
        options.policy = policy;
        options.capacity = policy == QueuePolicy::latest ? 16 : 0;
        return options;
    }

    InputQueue queue;
    MalformedCounter malformed;
};

class WorldProgram {
public:
    WorldProgram(Client& client, const WorldOptions& options)
        : options_(options),
          world_(options.seed),
          gaze_target_(client, options.prefix + "/gaze/target", QueuePolicy::latest),
          arm_target_(client, options.prefix + "/arm/target", QueuePolicy::latest),
          hand_command_(client, options.prefix + "/hand/command", QueuePolicy::latest),
          control_(client, options.prefix + "/control", QueuePolicy::strict),
          object_(client.open(options.prefix + "/object")),
          person_(client.open(options.prefix + "/person")),
          touch_(client.open(options.prefix + "/touch")),
          proximity_(client.open(options.prefix + "/hand/proximity")),
          head_(client.open(options.prefix + "/head")),
          arm_(client.open(options.prefix + "/arm")),
          hand_(client.open(options.prefix + "/hand")),
          phase_(client.open(options.prefix + "/phase")) {}

    int run() {
        const double dt = 1.0 / options_.rate;
        const auto period = std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(1.0 / (options_.rate * options_.speed)));
        std::cerr << program << ": seed " << options_.seed << ", " << options_.rate << " Hz sim, speed "
                  << options_.speed << ", ports under " << options_.prefix << '\n';
        auto next = Clock::now();
        bool first = true;
        while (!stop_requested()) {
            read_inputs();
            if (!first)
                world_.step(dt);
            publish(first);
            first = false;
            if (options_.log_state && world_.time() + 1e-9 >= next_state_log_) {
                log_state();
                next_state_log_ += 1.0;
            }
            if (options_.duration > 0 && world_.time() + dt / 2 >= options_.duration)
                break;
            next += period;
            const auto now = Clock::now();
            if (now > next + max_lag) {
                if (!warned_lag_)
                    std::cerr << program << ": falling behind real time; sim time runs slower than --speed\n";
                warned_lag_ = true;
                next = now;
            }
            std::this_thread::sleep_until(next);
        }
        for (const Input* input : {&gaze_target_, &arm_target_, &hand_command_, &control_}) {
            input->malformed.summarize();
            if (const auto dropped = input->queue.dropped())
                std::cerr << program << ": " << input->queue.name() << ": " << dropped
                          << " messages dropped, not taken in time\n";
        }
        std::cerr << program << ": stopped at t=" << world_.time() << " s after " << world_.deliveries()
                  << " deliveries\n";
        return 0;
    }

private:
    void read_inputs() {
        drain(gaze_target_, [this](const Json& data) {
            auto target = parse_gaze_target(data);
            if (!target)
                return target.error;
            std::visit([this](auto value) { world_.set_gaze_target(value); }, *target.value);
            return std::string();
        });
        drain(arm_target_, [this](const Json& data) {
            auto point = parse_point(data);
            if (!point)
                return point.error;
            world_.set_arm_target(*point.value);
            return std::string();
        });
        drain(hand_command_, [this](const Json& data) {
            auto close = parse_hand_command(data);
            if (!close)
                return close.error;
            world_.command_hand(*close.value);
            return std::string();
        });
        drain(control_, [this](const Json& data) {
            auto disturbance = parse_disturbance(data);
            if (!disturbance)
                return disturbance.error;
            const Outcome outcome = apply(world_, *disturbance.value);
            std::cerr << program << ": t=" << world_.time() << " control " << data.dump()
                      << (outcome.applied ? std::string(" applied")
                                          : " ignored: " + std::string(outcome.reason))
                      << '\n';
            return std::string();
        });
    }

    /// Applies what arrived on an input since the last tick; `handle` returns an error text or "".
    template <typename Handle>
    void drain(Input& input, Handle handle) {
        for (const Value& message : input.queue.take()) {
            const std::string error = handle(message);
            if (!error.empty())
                input.malformed.count(error);
        }
    }

    void publish(bool first) {
        // Everything is buffered and sent in one go by the last, flushing write: one send per tick.
        if (const auto object = object_message(world_))
            object_.write(*object, false);
        if (const auto person = person_message(world_))
            person_.write(*person, false);
        touch_.write(touch_message(world_), false);
        proximity_.write(proximity_message(world_), false);
        head_.write(head_message(world_), false);
        arm_.write(arm_message(world_), false);

        // The benchmark's latency runs from the tick the object came into view to the tick the
        // world judges "reach": how fast the components turned a sighting into an arm target.
        const bool visible = world_.object_visible();
        if (visible && !object_was_visible_)
            object_seen_at_ = Clock::now();
        object_was_visible_ = visible;

        const Phase phase = world_.phase();
        if (first || phase != last_phase_) {
            Json message = phase_message(world_);
            if (phase == Phase::reach && object_seen_at_)
                message["latency"] = std::chrono::duration<double>(Clock::now() - *object_seen_at_).count();
            phase_.write(message, false);
            std::cerr << program << ": " << message.dump() << '\n';
            last_phase_ = phase;
        }
        hand_.write(hand_message(world_), true);
    }

    void log_state() const {
        const auto object = world_.object();
        const auto person = world_.person();
        std::cerr << program << ": t=" << world_.time() << " phase=" << to_string(world_.phase())
                  << " gaze=" << world_.gaze() << " hand=(" << world_.hand().x << "," << world_.hand().y
                  << ") " << to_string(world_.hand_state()) << " object=" << to_string(world_.object_state());
        if (object)
            std::cerr << "(" << object->x << "," << object->y << ")"
                      << (world_.object_visible() ? " seen" : "");
        std::cerr << " person=";
        if (person)
            std::cerr << world_.person_angle() << (world_.person_visible() ? " seen" : "");
        else
            std::cerr << "away";
        std::cerr << " deliveries=" << world_.deliveries() << '\n';
    }

    WorldOptions options_;
    WorldModel world_;
    Input gaze_target_;
    Input arm_target_;
    Input hand_command_;
    Input control_;
    Port object_;
    Port person_;
    Port touch_;
    Port proximity_;
    Port head_;
    Port arm_;
    Port hand_;
    Port phase_;
    Phase last_phase_ = Phase::search_object;
    bool object_was_visible_ = false;
    std::optional<Clock::time_point> object_seen_at_;
    double next_state_log_ = 0;
    bool warned_lag_ = false;
};

}  // namespace

int run_world(const WorldOptions& options) {
    install_stop_handlers();
    try {
        Client client;
        WorldProgram world(client, options);
        return world.run();
    } catch (const Error& e) {
        std::cerr << program << ": " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
}

}  // namespace plexus::sim
