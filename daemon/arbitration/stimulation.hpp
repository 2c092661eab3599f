#pragma once
// Arbitration by stimulation (DESIGN, "Arbitration by stimulation"): each connection of a
// `recv.priority` clause is a leaky integrator, stimulated by its messages; the active ones
// excite or inhibit each other through weights, and the connection with the highest output wins.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon::arbitration {

/// The keys of a `recv.priority` clause.
struct PriorityParams {
    double tc = 1.0;  ///< decay time tau, seconds
    double tr = 0.0;  ///< resting time after a decay, seconds; 0 = no resting
    double st = 1.0;  ///< stimulation sigma added per message
    double bs = 1.0;  ///< bias beta
    /// ex: weights from this connection to the connections coming from these source ports.
    std::vector<std::pair<std::string, double>> ex;
    bool aux = false;

    /// Reads the clause's keys; errors name the bad key or value ("tc.abc: expected a number").
    static proto::Result<PriorityParams> from_clause(const proto::Clause& clause);
};

/// One connection's stimulation level over time.
class Stimulus {
public:
    explicit Stimulus(const PriorityParams& params) : tc_(params.tc), tr_(params.tr), st_(params.st) {}

    /// S(t): Sa * (1 - e^(5(dt - tc)/tc) + e^-5) for dt = t - Ta <= tc, else 0.
    double level(double t) const;
    /// x(t): 1 while S > 0 after S reached 1, else 0.
    bool active(double t) const {
        // S > 0 exactly while dt <= tc once Sa > 0 (and Sa >= 1 once reached): no exp needed.
        return reached_ && ta_ && t - *ta_ <= tc_;
    }
    bool resting(double t) const { return t < rest_until_; }
    /// A message at `t`: Sa <- min(1, S(t) + st), Ta <- t; ignored while resting.
    void stimulate(double t);

private:
    /// Applies what happened between the last message and `t`: a decay to 0, then the rest.
    void settle(double t);

    double tc_;
    double tr_;
    double st_;
    double sa_ = 0;
    std::optional<double> ta_;  ///< none before the first message
    bool reached_ = false;
    double rest_until_ = -1e300;
};

/// Solves (I - X * A^T) y = X * beta for y. `weights[j][i]` is alpha_ji, the weight from
/// connection j to connection i; `active[i]` is x_i. Fails with "inconsistent weights" when the
/// system is singular.
proto::Result<std::vector<double>> solve_outputs(const std::vector<std::vector<double>>& weights,
                                                 const std::vector<bool>& active,
                                                 const std::vector<double>& bias);
/// The same into `outputs`, with `matrix` as working space: no allocation once both have grown,
/// for the selection on every message. False when the system is singular.
bool solve_outputs_into(const std::vector<std::vector<double>>& weights, const std::vector<bool>& active,
                        const std::vector<double>& bias, std::vector<double>& matrix, std::vector<double>& outputs);

/// The index of the winner: the largest y_i > 0 among the connections that are not auxiliary;
/// ties go to the lowest index (the earliest connection). None when no output is positive.
std::optional<std::size_t> select_winner(const std::vector<double>& outputs,
                                         const std::vector<bool>& auxiliary);

}  // namespace plexus::daemon::arbitration
