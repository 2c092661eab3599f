// Arbitration by stimulation in isolation (DESIGN, "Arbitration by stimulation"): the leaky
// integrator against values worked out by hand, the recv.priority keys, the linear system
// (I - X*A^T) y = X*beta and the choice of the winner.
#include "arbitration/stimulation.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "plexus/proto/carrier.hpp"
#include "text_contains.hpp"

namespace plexus::daemon::arbitration {
namespace {

constexpr double t0 = 1000.0;
constexpr double tolerance = 1e-9;

PriorityParams params(double tc, double st, double tr = 0) {
    PriorityParams p;
    p.tc = tc;
    p.st = st;
    p.tr = tr;
    return p;
}

// ---------------------------------------------------------------------------------------------
// Stimulus: S(t) = Sa * (1 - e^(5(dt - tc)/tc) + e^-5) for dt <= tc, else 0.

TEST(Stimulus_test, NothingBeforeTheFirstMessage) {
    Stimulus s(params(1, 1));
    EXPECT_EQ(s.level(t0), 0.0);
    EXPECT_FALSE(s.active(t0));
    EXPECT_FALSE(s.resting(t0));
}

TEST(Stimulus_test, LevelRightAfterAMessageIsSa) {
    Stimulus s(params(1, 1));
    s.stimulate(t0);
    // dt = 0: 1 * (1 - e^(5(0-1)/1) + e^-5) = 1 - e^-5 + e^-5 = 1.
    EXPECT_NEAR(s.level(t0), 1.0, tolerance);
    EXPECT_TRUE(s.active(t0));
}

TEST(Stimulus_test, LevelHalfwayThroughTheDecayMatchesTheFormula) {
    Stimulus s(params(1, 1));
    s.stimulate(t0);
    // dt = 0.5: 1 * (1 - e^(5(0.5-1)/1) + e^-5) = 1 - e^-2.5 + e^-5
    //         = 1 - 0.082084998624 + 0.006737946999 = 0.924652948375.
    EXPECT_NEAR(s.level(t0 + 0.5), 0.924652948375, tolerance);
    EXPECT_TRUE(s.active(t0 + 0.5));
}

TEST(Stimulus_test, AtExactlyTcTheLevelIsEToTheMinusFiveAndStillActive) {
    Stimulus s(params(1, 1));
    s.stimulate(t0);
    // dt = tc = 1: 1 * (1 - e^0 + e^-5) = e^-5 = 0.006737946999.
    EXPECT_NEAR(s.level(t0 + 1.0), 0.006737946999, tolerance);
    EXPECT_TRUE(s.active(t0 + 1.0));
}

TEST(Stimulus_test, JustAfterTcTheLevelIsZeroAndInactive) {
    Stimulus s(params(1, 1));
    s.stimulate(t0);
    // dt = 1.0001 > tc: S = 0, so x = 0.
    EXPECT_EQ(s.level(t0 + 1.0001), 0.0);
    EXPECT_FALSE(s.active(t0 + 1.0001));
}

TEST(Stimulus_test, TheDecayScalesWithTc) {
    Stimulus s(params(0.5, 1));
    s.stimulate(t0);
    // tc = 0.5, dt = 0.25: 1 - e^(5(0.25-0.5)/0.5) + e^-5 = 1 - e^-2.5 + e^-5, as at half of tc = 1.
    EXPECT_NEAR(s.level(t0 + 0.25), 0.924652948375, tolerance);
    EXPECT_NEAR(s.level(t0 + 0.5), 0.006737946999, tolerance);
    EXPECT_EQ(s.level(t0 + 0.5001), 0.0);
}

TEST(Stimulus_test, AWeakStimulationIsNotActiveUntilTheLevelReachesOne) {
    Stimulus s(params(1, 0.5));
    s.stimulate(t0);
    // First message: Sa = min(1, 0 + 0.5) = 0.5. Not active: S never reached 1.
    EXPECT_NEAR(s.level(t0), 0.5, tolerance);
    EXPECT_FALSE(s.active(t0));

    s.stimulate(t0 + 0.2);
    // Second message 0.2 s later: S(0.2) = 0.5 * (1 - e^(5(0.2-1)) + e^-5) = 0.5 * (1 - e^-4 + e^-5)
    //   = 0.5 * (1 - 0.018315638889 + 0.006737946999) = 0.5 * 0.988422308110 = 0.494211154055;
    // Sa = min(1, 0.494211154055 + 0.5) = 0.994211154055 < 1: still not active.
    EXPECT_NEAR(s.level(t0 + 0.2), 0.994211154055, tolerance);
    EXPECT_FALSE(s.active(t0 + 0.2));

    s.stimulate(t0 + 0.4);
    // Third, 0.2 s later: 0.994211154055 * 0.988422308110 + 0.5 = 1.48...: capped at Sa = 1, active.
    EXPECT_NEAR(s.level(t0 + 0.4), 1.0, tolerance);
    EXPECT_TRUE(s.active(t0 + 0.4));
}

TEST(Stimulus_test, WeakStimulationsTooFarApartNeverAdd) {
    Stimulus s(params(1, 0.5));
    // Each message comes after the previous one decayed (dt > tc): Sa is 0.5 every time.
    for (int i = 0; i < 5; ++i) {
        s.stimulate(t0 + 1.5 * i);
        EXPECT_NEAR(s.level(t0 + 1.5 * i), 0.5, tolerance);
        EXPECT_FALSE(s.active(t0 + 1.5 * i));
    }
}

TEST(Stimulus_test, OnceActiveItStaysActiveWhileTheLevelIsAboveZero) {
    Stimulus s(params(1, 1));
    s.stimulate(t0);
    // Messages every 0.75 s keep it at the cap: S(0.75) + 1 >= 1.
    s.stimulate(t0 + 0.75);
    s.stimulate(t0 + 1.5);
    EXPECT_TRUE(s.active(t0 + 1.5));
    EXPECT_NEAR(s.level(t0 + 1.5), 1.0, tolerance);
    // And decays a full tc after the last one.
    EXPECT_TRUE(s.active(t0 + 2.5));
    EXPECT_FALSE(s.active(t0 + 2.5001));
}

TEST(Stimulus_test, AfterDecayingItMustReachOneAgainToBeActive) {
    Stimulus s(params(1, 0.5));
    s.stimulate(t0);
    s.stimulate(t0 + 0.2);
    s.stimulate(t0 + 0.4);
    ASSERT_TRUE(s.active(t0 + 0.4));
    // Decayed at t0 + 1.4; a single 0.5 message later is below the threshold again.
    s.stimulate(t0 + 2.0);
    EXPECT_NEAR(s.level(t0 + 2.0), 0.5, tolerance);
    EXPECT_FALSE(s.active(t0 + 2.0));
}

TEST(Stimulus_test, WithoutRestingADecayedConnectionIsStimulatedAtOnce) {
    Stimulus s(params(1, 1, 0));
    s.stimulate(t0);
    s.stimulate(t0 + 1.5);
    EXPECT_NEAR(s.level(t0 + 1.5), 1.0, tolerance);
    EXPECT_TRUE(s.active(t0 + 1.5));
}

TEST(Stimulus_test, RestingIgnoresMessagesUntilTcPlusTrAfterTheLastMessage) {
    Stimulus s(params(1, 1, 2));
    s.stimulate(t0);  // reached 1: Ta = 1000, decays at Ta + tc = 1001, rests until 1001 + tr = 1003
    ASSERT_TRUE(s.active(t0));
    // Within tc a message still stimulates: no resting yet.
    s.stimulate(t0 + 0.5);  // Ta = 1000.5: decays at 1001.5, rests until 1003.5
    EXPECT_NEAR(s.level(t0 + 0.5), 1.0, tolerance);

    s.stimulate(t0 + 1.6);  // decayed: the rest starts, this message is ignored
    EXPECT_TRUE(s.resting(t0 + 1.6));
    EXPECT_EQ(s.level(t0 + 1.6), 0.0);
    EXPECT_FALSE(s.active(t0 + 1.6));

    s.stimulate(t0 + 3.49);  // still resting
    EXPECT_EQ(s.level(t0 + 3.49), 0.0);
    EXPECT_FALSE(s.active(t0 + 3.49));

    s.stimulate(t0 + 3.5);  // 1000.5 + 1 + 2: the rest is over
    EXPECT_FALSE(s.resting(t0 + 3.5));
    EXPECT_NEAR(s.level(t0 + 3.5), 1.0, tolerance);
    EXPECT_TRUE(s.active(t0 + 3.5));
}

TEST(Stimulus_test, ARestIsCountedFromTheDecayNotFromTheFirstMessageAfterIt) {
    Stimulus s(params(1, 1, 2));
    s.stimulate(t0);
    // The first message after the decay comes at 1004, after the whole rest (1001..1003): it
    // stimulates, the rest having passed unseen.
    s.stimulate(t0 + 4.0);
    EXPECT_NEAR(s.level(t0 + 4.0), 1.0, tolerance);
    EXPECT_TRUE(s.active(t0 + 4.0));
}

TEST(Stimulus_test, OnlyAConnectionThatReachedOneRests) {
    Stimulus s(params(1, 0.5, 2));
    s.stimulate(t0);  // Sa = 0.5: never reached 1
    s.stimulate(t0 + 1.5);
    EXPECT_FALSE(s.resting(t0 + 1.5));
    EXPECT_NEAR(s.level(t0 + 1.5), 0.5, tolerance);
}

TEST(Stimulus_test, ZeroStimulationNeverActivates) {
    Stimulus s(params(1, 0));
    s.stimulate(t0);
    s.stimulate(t0 + 0.1);
    EXPECT_EQ(s.level(t0 + 0.1), 0.0);
    EXPECT_FALSE(s.active(t0 + 0.1));
}

// ---------------------------------------------------------------------------------------------
// PriorityParams: the keys of recv.priority.

proto::Clause clause_of(const std::string& carrier) {
    auto parsed = proto::parse_carrier(carrier);
    EXPECT_TRUE(parsed.ok()) << carrier << ": " << (parsed.ok() ? "" : parsed.error().message);
    if (!parsed.ok() || parsed->clauses.empty())
        return {};
    return parsed->clauses.front();
}

std::string params_error(const std::string& carrier) {
    auto read = PriorityParams::from_clause(clause_of(carrier));
    EXPECT_FALSE(read.ok()) << carrier << " was accepted";
    return read.ok() ? std::string() : read.error().message;
}

TEST(PriorityParams_test, DefaultsFollowTheDesign) {
    auto read = PriorityParams::from_clause(clause_of("tcp+recv.priority"));
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->tc, 1.0);
    EXPECT_EQ(read->tr, 0.0);
    EXPECT_EQ(read->st, 1.0);
    EXPECT_EQ(read->bs, 1.0);
    EXPECT_TRUE(read->ex.empty());
    EXPECT_FALSE(read->aux);
}

TEST(PriorityParams_test, ReadsEveryKey) {
    auto read = PriorityParams::from_clause(
        clause_of("tcp+recv.priority+tc.0.5+tr.2+st.0.25+bs.-1.5+ex./face/out:-1,/obj/out:0.5+aux"));
    ASSERT_TRUE(read.ok()) << read.error().message;
    EXPECT_EQ(read->tc, 0.5);
    EXPECT_EQ(read->tr, 2.0);
    EXPECT_EQ(read->st, 0.25);
    EXPECT_EQ(read->bs, -1.5);
    using Weights = std::vector<std::pair<std::string, double>>;
    EXPECT_EQ(read->ex, (Weights{{"/face/out", -1.0}, {"/obj/out", 0.5}}));
    EXPECT_TRUE(read->aux);
}

TEST(PriorityParams_test, PortNamesInExMayHoldColonsTheLastOneSplits) {
    auto read = PriorityParams::from_clause(clause_of("tcp+recv.priority+ex./face:o:-1,/a:b:c:2"));
    ASSERT_TRUE(read.ok()) << read.error().message;
    using Weights = std::vector<std::pair<std::string, double>>;
    EXPECT_EQ(read->ex, (Weights{{"/face:o", -1.0}, {"/a:b:c", 2.0}}));
}

TEST(PriorityParams_test, RefusesBadValues) {
    EXPECT_EQ(params_error("tcp+recv.priority+tc.abc"), "priority key tc.abc: expected a number");
    EXPECT_EQ(params_error("tcp+recv.priority+tc.0"), "priority tc must be > 0 seconds");
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+tc.-1"), "tc must be > 0"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+tr.-1"), "tr must be >= 0"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+st.-0.5"), "st must be >= 0"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+tc.1x"), "tc.1x: expected a number"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+tc.inf"), "expected a number"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+bs.nan"), "expected a number"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+st"), "'st' needs a value"));
}

TEST(PriorityParams_test, RefusesUnknownKeysNamingThem) {
    EXPECT_EQ(params_error("tcp+recv.priority+zz.1"),
              "unknown key 'zz' of recv.priority (keys: tc tr st bs ex aux)");
}

TEST(PriorityParams_test, RefusesMalformedWeights) {
    EXPECT_EQ(params_error("tcp+recv.priority+ex./face/out"),
              "priority ex./face/out: '/face/out' is not SOURCE:WEIGHT");
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex.face:-1"), "must start with '/'"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex.:-1"), "port name is empty"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex./face:x"), "weight 'x' is not a number"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex./face:"), "weight '' is not a number"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex./a:1,"), "'' is not SOURCE:WEIGHT"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+ex"), "'ex' needs SOURCE:WEIGHT pairs"));
    EXPECT_TRUE(contains(params_error("tcp+recv.priority+aux.1"), "'aux' is a flag"));
}

// ---------------------------------------------------------------------------------------------
// solve_outputs: y_i = x_i * (sum_j alpha_ji * y_j + beta_i); weights[j][i] is alpha_ji.

using Matrix = std::vector<std::vector<double>>;

void expect_outputs(const proto::Result<std::vector<double>>& y, const std::vector<double>& expected) {
    ASSERT_TRUE(y.ok()) << y.error().message;
    ASSERT_EQ(y->size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i)
        EXPECT_NEAR((*y)[i], expected[i], tolerance) << "y[" << i << "]";
}

// The gaze example: face C1 (index 0), object C2 (index 1), beta = 1 each, alpha_21 = -1 (the
// object inhibits the face): weights[1][0] = -1.
const Matrix gaze = {{0, 0}, {-1, 0}};

TEST(SolveOutputs_test, GazeBothActiveTheObjectInhibitsTheFace) {
    // y1 = 1 * (0 * y0 + 1) = 1; y0 = 1 * (-1 * y1 + 1) = 0.
    const auto y = solve_outputs(gaze, {true, true}, {1, 1});
    expect_outputs(y, {0, 1});
    EXPECT_EQ(select_winner(*y, {false, false}), 1u);
}

TEST(SolveOutputs_test, GazeOnlyTheFaceActive) {
    // y1 = 0 (x1 = 0); y0 = -1 * 0 + 1 = 1.
    const auto y = solve_outputs(gaze, {true, false}, {1, 1});
    expect_outputs(y, {1, 0});
    EXPECT_EQ(select_winner(*y, {false, false}), 0u);
}

TEST(SolveOutputs_test, NothingActiveGivesZerosAndNoWinner) {
    const auto y = solve_outputs(gaze, {false, false}, {1, 1});
    expect_outputs(y, {0, 0});
    EXPECT_EQ(select_winner(*y, {false, false}), std::nullopt);
}

// Auxiliary excitation: face aux (index 0, beta 1) excites the object (index 1, beta 0):
// alpha_12 = 1, weights[0][1] = 1.
const Matrix excitation = {{0, 1}, {0, 0}};

TEST(SolveOutputs_test, AuxiliaryExcitationBothActiveTheObjectWins) {
    // y0 = 1 * (0 + 1) = 1; y1 = 1 * (1 * y0 + 0) = 1. Face is auxiliary, so it never wins.
    const auto y = solve_outputs(excitation, {true, true}, {1, 0});
    expect_outputs(y, {1, 1});
    EXPECT_EQ(select_winner(*y, {true, false}), 1u);
}

TEST(SolveOutputs_test, AuxiliaryExcitationOnlyTheObjectActiveNobodyWins) {
    // y0 = 0 (x0 = 0); y1 = 1 * (1 * 0 + 0) = 0: no positive output.
    const auto y = solve_outputs(excitation, {false, true}, {1, 0});
    expect_outputs(y, {0, 0});
    EXPECT_EQ(select_winner(*y, {true, false}), std::nullopt);
}

TEST(SolveOutputs_test, AuxiliaryExcitationOnlyTheAuxiliaryActiveNobodyWins) {
    // y0 = 1, y1 = 0 (x1 = 0); the only positive output is the auxiliary one.
    const auto y = solve_outputs(excitation, {true, false}, {1, 0});
    expect_outputs(y, {1, 0});
    EXPECT_EQ(select_winner(*y, {true, false}), std::nullopt);
}

// Three connections in a ring: 0 -> 1 with 0.5, 1 -> 2 with -0.5, 2 -> 0 with 0.25; beta = 1.
const Matrix ring = {{0, 0.5, 0}, {0, 0, -0.5}, {0.25, 0, 0}};

TEST(SolveOutputs_test, ThreeByThreeAllActiveSolvedByHand) {
    // y0 = 0.25 y2 + 1, y1 = 0.5 y0 + 1, y2 = -0.5 y1 + 1.
    // y1 = 0.5 (0.25 y2 + 1) + 1 = 0.125 y2 + 1.5
    // y2 = -0.5 (0.125 y2 + 1.5) + 1 = -0.0625 y2 + 0.25  =>  1.0625 y2 = 0.25  =>  y2 = 4/17
    // y0 = 0.25 * 4/17 + 1 = 18/17;  y1 = 0.5 * 18/17 + 1 = 26/17.
    const auto y = solve_outputs(ring, {true, true, true}, {1, 1, 1});
    expect_outputs(y, {18.0 / 17, 26.0 / 17, 4.0 / 17});
    EXPECT_EQ(select_winner(*y, {false, false, false}), 1u);
}

TEST(SolveOutputs_test, ThreeByThreeWithTheFirstInactiveSolvedByHand) {
    // x0 = 0: y0 = 0; y1 = 0.5 * 0 + 1 = 1; y2 = -0.5 * 1 + 1 = 0.5.
    const auto y = solve_outputs(ring, {false, true, true}, {1, 1, 1});
    expect_outputs(y, {0, 1, 0.5});
}

TEST(SolveOutputs_test, AnInactiveConnectionHasZeroOutputHoweverExcited) {
    const Matrix strong = {{0, 5}, {0, 0}};
    const auto y = solve_outputs(strong, {true, false}, {1, 1});
    expect_outputs(y, {1, 0});
}

TEST(SolveOutputs_test, AZeroOnTheDiagonalIsPivotedAroundNotCalledSingular) {
    // Self-excitation weights[0][0] = 1 zeroes the first diagonal entry; weights[1][0] = -1,
    // weights[0][1] = 1. Rows: (1 - 1) y0 + y1 = 1 and -y0 + y1 = 1  =>  y1 = 1, y0 = 0.
    const Matrix weights = {{1, 1}, {-1, 0}};
    expect_outputs(solve_outputs(weights, {true, true}, {1, 1}), {0, 1});
}

TEST(SolveOutputs_test, MutualExcitationWithBothActiveIsInconsistent) {
    // y0 = y1 + 1 and y1 = y0 + 1 have no solution: I - X*A^T = [[1, -1], [-1, 1]] is singular.
    const Matrix mutual = {{0, 1}, {1, 0}};
    const auto y = solve_outputs(mutual, {true, true}, {1, 1});
    ASSERT_FALSE(y.ok());
    EXPECT_TRUE(contains(y.error().message, "inconsistent weights")) << y.error().message;
}

TEST(SolveOutputs_test, MutualExcitationWithOneInactiveIsFine) {
    const Matrix mutual = {{0, 1}, {1, 0}};
    // x1 = 0: y1 = 0, y0 = 1 * 0 + 1 = 1.
    expect_outputs(solve_outputs(mutual, {true, false}, {1, 1}), {1, 0});
    expect_outputs(solve_outputs(mutual, {false, true}, {1, 1}), {0, 1});
}

TEST(SolveOutputs_test, NoConnectionsNoOutputs) {
    const auto y = solve_outputs({}, {}, {});
    ASSERT_TRUE(y.ok());
    EXPECT_TRUE(y->empty());
    EXPECT_EQ(select_winner(*y, {}), std::nullopt);
}

// ---------------------------------------------------------------------------------------------
// select_winner

TEST(SelectWinner_test, TheLargestOutputWins) {
    EXPECT_EQ(select_winner({0.2, 0.9, 0.5}, {false, false, false}), 1u);
    EXPECT_EQ(select_winner({0.2, 0.5, 0.9}, {false, false, false}), 2u);
}

TEST(SelectWinner_test, TiesGoToTheLowestIndex) {
    EXPECT_EQ(select_winner({1, 1}, {false, false}), 0u);
    EXPECT_EQ(select_winner({0.5, 1, 1, 1}, {false, false, false, false}), 1u);
    // Rounding noise is no reason to prefer a later connection.
    EXPECT_EQ(select_winner({1, 1 + 1e-15}, {false, false}), 0u);
}

TEST(SelectWinner_test, ZeroOrNegativeOutputsNeverWin) {
    EXPECT_EQ(select_winner({0, 0}, {false, false}), std::nullopt);
    EXPECT_EQ(select_winner({-1, -0.5}, {false, false}), std::nullopt);
    EXPECT_EQ(select_winner({-1, 0, 0.25}, {false, false, false}), 2u);
}

TEST(SelectWinner_test, AuxiliaryConnectionsNeverWinEvenWithTheLargestOutput) {
    EXPECT_EQ(select_winner({2, 1}, {true, false}), 1u);
    EXPECT_EQ(select_winner({2, 0}, {true, false}), std::nullopt);
}

}  // namespace
}  // namespace plexus::daemon::arbitration
