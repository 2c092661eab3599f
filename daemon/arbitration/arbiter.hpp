#pragma once
// Threading: an Arbiter and its Members are shared by the daemon's thread and the monitor workers
// of the port's connections: every use holds mutex() (a leaf lock: nothing else is taken while it is
// held, and no script runs under it). Only Member's destructor takes it by itself.
//
// The arbitration of one input port: its event container, and for each connection into it
// (a Member) the constraint, the auxiliary flag and the stimulation state that decide whether a
// message that passed the monitors' accept is delivered.

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "clock.hpp"
#include "consistency.hpp"
#include "constraint.hpp"
#include "events.hpp"
#include "stimulation.hpp"

namespace plexus::daemon::arbitration {

class Arbiter;

/// One connection's place in its input port's arbitration. Made before the connection's monitors
/// (they set events and constraints through it); joins the arbiter once the connection is made.
class Member {
public:
    Member(std::shared_ptr<Arbiter> arbiter, std::string source)
        : arbiter_(std::move(arbiter)), source_(std::move(source)) {}
    ~Member();
    Member(const Member&) = delete;
    Member& operator=(const Member&) = delete;

    Arbiter& arbiter() const { return *arbiter_; }
    const std::string& source() const { return source_; }

    /// From the carrier's `constraint.` key or a script's setConstraint; none = always true.
    std::optional<Constraint> constraint;
    bool aux = false;
    std::optional<PriorityParams> priority;
    std::optional<Stimulus> stimulus;  ///< present with `priority`

    void set_priority(const PriorityParams& params) {
        priority = params;
        stimulus.emplace(params);
        aux = aux || params.aux;
    }
    /// Nothing to decide: the fast path delivers without asking the arbiter.
    bool trivial() const { return !constraint && !priority && !aux; }

    std::uint64_t dropped_by_constraint = 0;
    std::uint64_t dropped_by_priority = 0;

private:
    friend class Arbiter;
    std::shared_ptr<Arbiter> arbiter_;
    std::string source_;
    bool joined_ = false;
};

/// The stimulation system at one instant, for the selection and for `plexus events`.
struct PriorityState {
    std::vector<const Member*> members;  ///< the stimulated connections, earliest first
    std::vector<double> level;           ///< S
    std::vector<bool> active;            ///< x
    std::vector<double> output;          ///< y (zeros when inconsistent)
    std::optional<std::size_t> winner;
    std::optional<std::string> error;  ///< "inconsistent weights: ..."
};

class Arbiter {
public:
    explicit Arbiter(const Clock& clock) : clock_(clock) {}

    /// Held by every caller of what follows (see the top of this file).
    std::mutex& mutex() const { return mutex_; }

    enum class Verdict { deliver, constraint, priority, auxiliary };
    /// For a message from `member` that passed accept: its constraint, then the stimulation
    /// selection, both at one instant `now` (a recording keeps it, so that a replay decides the
    /// same). Counts the drops on the member.
    Verdict admit(Member& member, double now);
    Verdict admit(Member& member) { return admit(member, clock_.now()); }
    /// "delivered", "constraint", "priority", "auxiliary": as recordings and what-if name them.
    static const char* verdict_name(Verdict verdict);

    /// While someone records the port's decisions (a tap), the monitors' stages note the time of
    /// each step. Read without the lock, on every message: an atomic flag, nothing more.
    bool watched() const { return watched_.load(std::memory_order_relaxed); }
    void set_watched(bool watched) { watched_.store(watched, std::memory_order_relaxed); }

    double now() const { return clock_.now(); }
    EventContainer& events() { return events_; }
    bool has_event(const std::string& name) const { return events_.has(name, clock_.now()); }
    /// The member's constraint now (or at `now`); true without one.
    bool constraint_value(const Member& member) const { return constraint_value(member, clock_.now()); }
    bool constraint_value(const Member& member, double now) const;
    PriorityState priority_state() const;

    /// Before a member joins: the weights must give a solvable system for every set of active
    /// connections (every subset up to 12 stimulated connections; past that, all active).
    proto::Status check_weights(const Member& candidate) const;
    /// Pairs of non-auxiliary members whose constraints can both be true (DESIGN, consistency
    /// check); with `candidate`, as if it had joined, and only the pairs that include it.
    struct Pair {
        std::string first;
        std::string second;
        std::optional<std::map<std::string, bool>> witness;
    };
    std::vector<Pair> overlaps(const Member* candidate = nullptr) const;
    /// Whether any member has a constraint: only then does connect warn about overlaps.
    bool uses_constraints(const Member* candidate = nullptr) const;

    void join(Member& member);
    void leave(Member& member);
    const std::vector<Member*>& members() const { return members_; }

private:
    std::vector<const Member*> stimulated(const Member* candidate) const;
    static std::vector<std::vector<double>> weight_matrix(const std::vector<const Member*>& members);
    void refresh_weights();

    mutable std::mutex mutex_;
    const Clock& clock_;
    std::atomic<bool> watched_{false};
    EventContainer events_;
    std::vector<Member*> members_;  ///< in connection order: ties go to the earliest
    // Cached for the per-message selection; rebuilt when members join or leave.
    std::vector<const Member*> stimulated_;
    std::vector<std::vector<double>> weights_;
    std::vector<double> bias_;
    std::vector<bool> auxiliary_;
    // Working space of the per-message selection, kept to avoid allocating on every message.
    std::vector<bool> active_;
    std::vector<double> matrix_;
    std::vector<double> outputs_;
};

}  // namespace plexus::daemon::arbitration
