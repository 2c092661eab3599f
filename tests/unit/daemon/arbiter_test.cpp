// The arbitration of one input port with a clock the test moves: the verdicts of admit() for the
// DESIGN scenarios (gaze, auxiliary excitation, trackers with constraints, lifetimes), the weight
// check that refuses singular configurations, and the consistency check's overlapping pairs.
// Events normally come from the monitors; here the tests set them on the container directly.
#include "arbitration/arbiter.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arbitration/carrier_rules.hpp"
#include "arbitration/clock.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon::arbitration {
namespace {

using Verdict = Arbiter::Verdict;

struct Arbiter_test : ::testing::Test {
    ManualClock clock;  // starts at 1000 s
    std::shared_ptr<Arbiter> arbiter = std::make_shared<Arbiter>(clock);

    // A member configured from `carrier`, not joined yet.
    std::shared_ptr<Member> make(const std::string& source, const std::string& carrier) {
        auto member = std::make_shared<Member>(arbiter, source);
        auto parsed = proto::parse_carrier(carrier);
        EXPECT_TRUE(parsed.ok()) << carrier << ": " << (parsed.ok() ? "" : parsed.error().message);
        if (parsed.ok()) {
            auto status = configure_member(*member, *parsed);
            EXPECT_TRUE(status.ok()) << carrier << ": " << (status.ok() ? "" : status.error().message);
        }
        return member;
    }

    // As connect does it: configure, check the weights, join.
    std::shared_ptr<Member> connect(const std::string& source, const std::string& carrier) {
        auto member = make(source, carrier);
        auto weights = arbiter->check_weights(*member);
        EXPECT_TRUE(weights.ok()) << source << ": " << (weights.ok() ? "" : weights.error().message);
        arbiter->join(*member);
        return member;
    }

    void set_event(const std::string& name, std::uint64_t owner,
                   std::optional<double> lifetime = std::nullopt) {
        arbiter->events().set(name, owner, "monitor " + std::to_string(owner), lifetime, clock.now());
    }
};

// ---------------------------------------------------------------------------------------------
// Stimulation: the gaze example. Face C1 and object C2, beta = 1 each, the object inhibits the face
// (alpha_21 = -1: the object's clause says ex./face/out:-1). tc = 0.5 s.

struct Gaze_test : Arbiter_test {
    std::shared_ptr<Member> face = connect("/face/out", "tcp+recv.priority+tc.0.5");
    std::shared_ptr<Member> object = connect("/object/out", "tcp+recv.priority+tc.0.5+ex./face/out:-1");
};

TEST_F(Gaze_test, FaceAloneIsDelivered) {
    EXPECT_EQ(arbiter->admit(*face), Verdict::deliver);
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*face), Verdict::deliver);
    EXPECT_EQ(face->dropped_by_priority, 0u);
}

TEST_F(Gaze_test, WhileAnObjectIsSeenOnlyTheObjectIsDelivered) {
    EXPECT_EQ(arbiter->admit(*face), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);  // y = {0, 1}
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
    EXPECT_EQ(face->dropped_by_priority, 2u);
    EXPECT_EQ(object->dropped_by_priority, 0u);

    const auto state = arbiter->priority_state();
    ASSERT_EQ(state.members.size(), 2u);
    EXPECT_EQ(state.members[0], face.get());
    EXPECT_EQ(state.members[1], object.get());
    EXPECT_EQ(state.active, (std::vector<bool>{true, true}));
    ASSERT_EQ(state.output.size(), 2u);
    EXPECT_NEAR(state.output[0], 0.0, 1e-9);
    EXPECT_NEAR(state.output[1], 1.0, 1e-9);
    EXPECT_EQ(state.winner, 1u);
    EXPECT_FALSE(state.error.has_value());
}

TEST_F(Gaze_test, WhenTheObjectStopsTheFaceWinsAgainJustAfterTc) {
    arbiter->admit(*face);
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);  // the object's last message, at 1000.25
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
    // 1000.75: dt = tc exactly, the object's S = e^-5 > 0, it is still active and inhibits.
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
    EXPECT_TRUE(arbiter->priority_state().active[1]);
    // 0.1 ms later the object has decayed: x2 = 0, y = {1, 0}.
    clock.advance(0.0001);
    EXPECT_EQ(arbiter->admit(*face), Verdict::deliver);
    EXPECT_FALSE(arbiter->priority_state().active[1]);
    EXPECT_EQ(face->dropped_by_priority, 2u);
}

TEST_F(Gaze_test, TheFaceDecaysTooWhenItStopsAndTheObjectKeepsWinning) {
    arbiter->admit(*face);
    arbiter->admit(*object);
    clock.advance(1.0);  // both decayed
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
}

TEST_F(Gaze_test, AMemberThatLeavesNoLongerInhibits) {
    arbiter->admit(*face);
    arbiter->admit(*object);
    ASSERT_EQ(arbiter->admit(*face), Verdict::priority);
    object.reset();  // the connection goes away: ~Member leaves the arbiter
    EXPECT_EQ(arbiter->members().size(), 1u);
    EXPECT_EQ(arbiter->priority_state().members.size(), 1u);
    EXPECT_EQ(arbiter->admit(*face), Verdict::deliver);
}

TEST_F(Gaze_test, AnObjectConnectionMadeAgainInhibitsAgain) {
    object.reset();
    object = connect("/object/out", "tcp+recv.priority+tc.0.5+ex./face/out:-1");
    arbiter->admit(*face);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
}

TEST_F(Arbiter_test, TheInhibitionWorksWhicheverOrderTheConnectionsJoin) {
    // The object (with the ex. weight) joins first, the face it names later.
    auto object = connect("/object/out", "tcp+recv.priority+tc.0.5+ex./face/out:-1");
    auto face = connect("/face/out", "tcp+recv.priority+tc.0.5");
    arbiter->admit(*object);
    EXPECT_EQ(arbiter->admit(*face), Verdict::priority);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
}

TEST_F(Arbiter_test, EqualOutputsGoToTheEarliestConnection) {
    auto first = connect("/first/out", "tcp+recv.priority");
    auto second = connect("/second/out", "tcp+recv.priority");
    arbiter->admit(*second);
    EXPECT_EQ(arbiter->admit(*first), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*second), Verdict::priority);  // y = {1, 1}: the earliest wins
}

TEST_F(Arbiter_test, ALaterEqualPeerDoesNotWinButAHigherBiasDoes) {
    auto low = connect("/low/out", "tcp+recv.priority+bs.1");
    auto high = connect("/high/out", "tcp+recv.priority+bs.2");
    arbiter->admit(*low);
    EXPECT_EQ(arbiter->admit(*high), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*low), Verdict::priority);
}

TEST_F(Arbiter_test, AWeakSourceIsNotDeliveredUntilItsLevelReachesOne) {
    auto weak = connect("/weak/out", "tcp+recv.priority+st.0.5");
    EXPECT_EQ(arbiter->admit(*weak), Verdict::priority);  // Sa = 0.5: not active, y = 0
    clock.advance(0.25);
    // Sa = 0.5 * (1 - e^(5(0.25-1)) + e^-5) + 0.5 = 0.5 * 0.983219... + 0.5 < 1: still not.
    EXPECT_EQ(arbiter->admit(*weak), Verdict::priority);
    clock.advance(0.25);
    EXPECT_EQ(arbiter->admit(*weak), Verdict::deliver);  // ~0.99 * 0.92 + 0.5 > 1: active
    EXPECT_EQ(weak->dropped_by_priority, 2u);
}

// ---------------------------------------------------------------------------------------------
// Auxiliary excitation: an auxiliary face connection (beta 1) excites the object (beta 0) with
// alpha_12 = 1: object data only while a face is also seen.

struct AuxiliaryExcitation_test : Arbiter_test {
    std::shared_ptr<Member> face = connect("/face/out", "tcp+recv.priority+aux+ex./object/out:1");
    std::shared_ptr<Member> object = connect("/object/out", "tcp+recv.priority+bs.0");
};

TEST_F(AuxiliaryExcitation_test, TheObjectAloneIsNotDelivered) {
    // y_object = 1 * (1 * 0 + 0) = 0: nobody wins.
    EXPECT_EQ(arbiter->admit(*object), Verdict::priority);
    EXPECT_EQ(object->dropped_by_priority, 1u);
    EXPECT_EQ(arbiter->priority_state().winner, std::nullopt);
}

TEST_F(AuxiliaryExcitation_test, WithAFaceSeenTheObjectIsDeliveredAndTheFaceNever) {
    EXPECT_EQ(arbiter->admit(*face), Verdict::auxiliary);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);  // y = {1, 1}: the face is auxiliary
    EXPECT_EQ(arbiter->admit(*face), Verdict::auxiliary);
    // Auxiliary messages are not delivered, but they are not priority drops either.
    EXPECT_EQ(face->dropped_by_priority, 0u);
    EXPECT_EQ(object->dropped_by_priority, 0u);
}

TEST_F(AuxiliaryExcitation_test, WhenTheFaceDecaysTheObjectIsDroppedAgain) {
    arbiter->admit(*face);  // at 1000, tc = 1: active until 1001
    clock.advance(0.5);
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
    clock.advance(0.5);  // 1001: dt = tc for the face, still active
    EXPECT_EQ(arbiter->admit(*object), Verdict::deliver);
    clock.advance(0.001);
    EXPECT_EQ(arbiter->admit(*object), Verdict::priority);
}

TEST_F(Arbiter_test, AnAuxiliaryPortmonitorConnectionIsNeverDelivered) {
    auto detector = connect("/detector/out", "tcp+recv.portmonitor+type.lua+file.detector+aux");
    EXPECT_EQ(arbiter->admit(*detector), Verdict::auxiliary);
    EXPECT_EQ(detector->dropped_by_constraint, 0u);
    EXPECT_EQ(detector->dropped_by_priority, 0u);
}

TEST_F(Arbiter_test, APlainConnectionIsDelivered) {
    auto plain = connect("/plain/out", "tcp");
    EXPECT_TRUE(plain->trivial());
    EXPECT_EQ(arbiter->admit(*plain), Verdict::deliver);
}

// ---------------------------------------------------------------------------------------------
// Constraints over events.

TEST_F(Arbiter_test, TrackersTheMoreTrustedWinsByConstraint) {
    auto templ = connect("/tmpl/out", "tcp+recv.portmonitor+constraint.e_template_ok and not e_particle_ok");
    auto particle = connect("/pf/out", "tcp+recv.portmonitor+constraint.e_particle_ok");
    constexpr std::uint64_t template_monitor = 1;
    constexpr std::uint64_t particle_monitor = 2;

    // No events: neither passes.
    EXPECT_EQ(arbiter->admit(*templ), Verdict::constraint);
    EXPECT_EQ(arbiter->admit(*particle), Verdict::constraint);

    set_event("e_template_ok", template_monitor);
    EXPECT_EQ(arbiter->admit(*templ), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*particle), Verdict::constraint);

    set_event("e_particle_ok", particle_monitor);  // the particle filter is trusted more
    EXPECT_EQ(arbiter->admit(*templ), Verdict::constraint);
    EXPECT_EQ(arbiter->admit(*particle), Verdict::deliver);

    arbiter->events().unset("e_particle_ok", particle_monitor);
    EXPECT_EQ(arbiter->admit(*templ), Verdict::deliver);

    EXPECT_EQ(templ->dropped_by_constraint, 2u);
    EXPECT_EQ(particle->dropped_by_constraint, 2u);
    EXPECT_EQ(templ->dropped_by_priority, 0u);
    EXPECT_EQ(particle->dropped_by_priority, 0u);
}

TEST_F(Arbiter_test, ConstraintValueFollowsTheEventsNow) {
    auto member = connect("/a/out", "tcp+recv.portmonitor+constraint.e_ball and not e_ball_selected");
    auto plain = connect("/b/out", "tcp");
    EXPECT_TRUE(arbiter->constraint_value(*plain));  // no constraint: always true
    EXPECT_FALSE(arbiter->constraint_value(*member));
    set_event("e_ball_selected", 1);  // a longer name that starts with e_ball: not e_ball
    EXPECT_FALSE(arbiter->constraint_value(*member));
    set_event("e_ball", 1);
    EXPECT_FALSE(arbiter->constraint_value(*member));
    arbiter->events().unset("e_ball_selected", 1);
    EXPECT_TRUE(arbiter->constraint_value(*member));
    EXPECT_TRUE(arbiter->has_event("e_ball"));
    EXPECT_FALSE(arbiter->has_event("e_ball_selected"));
}

TEST_F(Arbiter_test, AnExpiringEventReleasesTheOtherSourceExactlyOnTime) {
    auto primary = connect("/primary/out", "tcp+recv.portmonitor+constraint.e_primary_ok");
    auto backup = connect("/backup/out", "tcp+recv.portmonitor+constraint.not e_primary_ok");
    set_event("e_primary_ok", 7, 0.5);  // at 1000, until 1000.5

    EXPECT_EQ(arbiter->admit(*primary), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*backup), Verdict::constraint);
    clock.advance(0.49);
    EXPECT_EQ(arbiter->admit(*primary), Verdict::deliver);
    EXPECT_EQ(arbiter->admit(*backup), Verdict::constraint);
    clock.advance(0.02);  // 1000.51: expired
    EXPECT_EQ(arbiter->admit(*primary), Verdict::constraint);
    EXPECT_EQ(arbiter->admit(*backup), Verdict::deliver);

    EXPECT_EQ(primary->dropped_by_constraint, 1u);
    EXPECT_EQ(backup->dropped_by_constraint, 2u);
}

TEST_F(Arbiter_test, TheConstraintComesFirstAndADroppedMessageDoesNotStimulate) {
    auto gated = connect("/gated/out", "tcp+recv.priority+recv.portmonitor+constraint.e_go");
    EXPECT_EQ(arbiter->admit(*gated), Verdict::constraint);
    EXPECT_EQ(gated->dropped_by_constraint, 1u);
    EXPECT_EQ(gated->dropped_by_priority, 0u);
    EXPECT_FALSE(arbiter->priority_state().active[0]);
    set_event("e_go", 1);
    EXPECT_EQ(arbiter->admit(*gated), Verdict::deliver);
}

TEST_F(Arbiter_test, AnAuxiliaryConnectionWhoseConstraintFailsCountsAConstraintDrop) {
    auto aux = connect("/aux/out", "tcp+recv.portmonitor+aux+constraint.e_go");
    EXPECT_EQ(arbiter->admit(*aux), Verdict::constraint);
    EXPECT_EQ(aux->dropped_by_constraint, 1u);
    set_event("e_go", 1);
    EXPECT_EQ(arbiter->admit(*aux), Verdict::auxiliary);
}

// ---------------------------------------------------------------------------------------------
// The weight check.

TEST_F(Arbiter_test, MutualExcitationIsRefusedAsInconsistentWeights) {
    auto a = connect("/a/out", "tcp+recv.priority+ex./b/out:1");
    auto b = make("/b/out", "tcp+recv.priority+ex./a/out:1");
    const auto status = arbiter->check_weights(*b);
    ASSERT_FALSE(status.ok());
    EXPECT_NE(status.error().message.find("inconsistent weights"), std::string::npos)
        << status.error().message;
    EXPECT_NE(status.error().message.find("/a/out, /b/out"), std::string::npos) << status.error().message;
    // The check does not join: the arbiter still has the one member.
    EXPECT_EQ(arbiter->members().size(), 1u);
    EXPECT_EQ(arbiter->priority_state().members.size(), 1u);
}

TEST_F(Arbiter_test, InhibitionOneWayAndExcitationTheOtherIsConsistent) {
    // y_a = -y_b + 1, y_b = y_a + 1  =>  y_a = 0, y_b = 1: a unique solution.
    auto a = connect("/a/out", "tcp+recv.priority+ex./b/out:1");
    auto b = make("/b/out", "tcp+recv.priority+ex./a/out:-1");
    EXPECT_TRUE(arbiter->check_weights(*b).ok());
}

TEST_F(Arbiter_test, AConfigurationSingularOnlyForSomeActiveConnectionsIsRefused) {
    // a -> b 1, a -> c 0.5, c -> a 1, and the candidate b -> a 1. With all three active,
    // det(I - A^T) = det [[1, -1, -1], [-1, 1, 0], [-0.5, 0, 1]] = 1 - 1 - 0.5 = -0.5: solvable.
    // With only a and b active, [[1, -1], [-1, 1]] is singular: the check must try that subset.
    auto a = connect("/a/out", "tcp+recv.priority+ex./b/out:1,/c/out:0.5");
    auto c = connect("/c/out", "tcp+recv.priority+ex./a/out:1");
    auto b = make("/b/out", "tcp+recv.priority+ex./a/out:1");
    const auto status = arbiter->check_weights(*b);
    ASSERT_FALSE(status.ok());
    EXPECT_NE(status.error().message.find("with the connections from /a/out, /b/out active"),
              std::string::npos)
        << status.error().message;
}

TEST_F(Arbiter_test, ACandidateWithoutPriorityNeedsNoWeightCheck) {
    auto a = connect("/a/out", "tcp+recv.priority+ex./b/out:1");
    auto b = make("/b/out", "tcp");
    EXPECT_TRUE(arbiter->check_weights(*b).ok());
}

TEST_F(Arbiter_test, AnInconsistentSystemThatGotInAnywayDeliversNothingAndSaysWhy) {
    auto a = connect("/a/out", "tcp+recv.priority+ex./b/out:1");
    auto b = make("/b/out", "tcp+recv.priority+ex./a/out:1");
    arbiter->join(*b);  // without the check
    arbiter->admit(*a);
    EXPECT_EQ(arbiter->admit(*b), Verdict::priority);
    const auto state = arbiter->priority_state();
    ASSERT_TRUE(state.error.has_value());
    EXPECT_NE(state.error->find("inconsistent weights"), std::string::npos);
    EXPECT_EQ(state.output, (std::vector<double>{0, 0}));
    EXPECT_EQ(state.winner, std::nullopt);
}

TEST_F(Arbiter_test, JoiningTwiceAddsTheMemberOnce) {
    auto a = connect("/a/out", "tcp+recv.priority");
    arbiter->join(*a);
    EXPECT_EQ(arbiter->members().size(), 1u);
    EXPECT_EQ(arbiter->priority_state().members.size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// The consistency check: pairs of non-auxiliary members whose constraints can both be true.

TEST_F(Arbiter_test, TrackersWithExclusiveConstraintsDoNotOverlap) {
    auto templ = connect("/tmpl/out", "tcp+recv.portmonitor+constraint.e_template_ok and not e_particle_ok");
    auto particle = connect("/pf/out", "tcp+recv.portmonitor+constraint.e_particle_ok");
    EXPECT_TRUE(arbiter->overlaps().empty());
    EXPECT_TRUE(arbiter->uses_constraints());
}

TEST_F(Arbiter_test, TrackersThatCanBothBeOkOverlapWithAWitness) {
    auto templ = connect("/tmpl/out", "tcp+recv.portmonitor+constraint.e_template_ok");
    auto particle = connect("/pf/out", "tcp+recv.portmonitor+constraint.e_particle_ok");
    const auto pairs = arbiter->overlaps();
    ASSERT_EQ(pairs.size(), 1u);
    EXPECT_EQ(pairs[0].first, "/tmpl/out");
    EXPECT_EQ(pairs[0].second, "/pf/out");
    ASSERT_TRUE(pairs[0].witness.has_value());
    EXPECT_EQ(*pairs[0].witness,
              (std::map<std::string, bool>{{"e_particle_ok", true}, {"e_template_ok", true}}));
}

TEST_F(Arbiter_test, TheWitnessGivesAbsentEventsAsFalse) {
    auto a = connect("/a/out", "tcp+recv.portmonitor+constraint.not e_x");
    auto b = connect("/b/out", "tcp+recv.portmonitor+constraint.not e_y");
    const auto pairs = arbiter->overlaps();
    ASSERT_EQ(pairs.size(), 1u);
    EXPECT_EQ(*pairs[0].witness, (std::map<std::string, bool>{{"e_x", false}, {"e_y", false}}));
}

TEST_F(Arbiter_test, AConnectionWithoutConstraintOverlapsEveryOther) {
    auto unconstrained = connect("/free/out", "tcp");
    auto gated = connect("/gated/out", "tcp+recv.portmonitor+constraint.e_x");
    const auto pairs = arbiter->overlaps();
    ASSERT_EQ(pairs.size(), 1u);
    EXPECT_EQ(pairs[0].first, "/free/out");
    EXPECT_EQ(pairs[0].second, "/gated/out");
    EXPECT_EQ(*pairs[0].witness, (std::map<std::string, bool>{{"e_x", true}}));
}

TEST_F(Arbiter_test, TwoConnectionsWithoutConstraintsOverlapWithAnEmptyWitness) {
    auto a = connect("/a/out", "tcp");
    auto b = connect("/b/out", "tcp");
    const auto pairs = arbiter->overlaps();
    ASSERT_EQ(pairs.size(), 1u);
    ASSERT_TRUE(pairs[0].witness.has_value());
    EXPECT_TRUE(pairs[0].witness->empty());
    EXPECT_FALSE(arbiter->uses_constraints());
}

TEST_F(Arbiter_test, AConstraintThatIsNeverTrueOverlapsNothing) {
    auto unconstrained = connect("/free/out", "tcp");
    auto never = connect("/never/out", "tcp+recv.portmonitor+constraint.e_x and not e_x");
    EXPECT_TRUE(arbiter->overlaps().empty());
}

TEST_F(Arbiter_test, AuxiliaryConnectionsAreLeftOutOfTheCheck) {
    auto aux = connect("/aux/out", "tcp+recv.portmonitor+type.lua+file.detector+aux");
    auto gated = connect("/gated/out", "tcp+recv.portmonitor+constraint.e_x");
    EXPECT_TRUE(arbiter->overlaps().empty());
    // Also as a candidate.
    auto aux2 = make("/aux2/out", "tcp+recv.portmonitor+aux");
    EXPECT_TRUE(arbiter->overlaps(aux2.get()).empty());
}

TEST_F(Arbiter_test, StimulatedConnectionsAreNotReportedAgainstEachOther) {
    auto face = connect("/face/out", "tcp+recv.priority");
    auto object = connect("/object/out", "tcp+recv.priority+ex./face/out:-1");
    EXPECT_TRUE(arbiter->overlaps().empty());
    // But a connection outside the stimulation overlaps each of them.
    auto plain = connect("/plain/out", "tcp");
    const auto pairs = arbiter->overlaps();
    ASSERT_EQ(pairs.size(), 2u);
    EXPECT_EQ(pairs[0].first, "/face/out");
    EXPECT_EQ(pairs[0].second, "/plain/out");
    EXPECT_EQ(pairs[1].first, "/object/out");
    EXPECT_EQ(pairs[1].second, "/plain/out");
}

TEST_F(Arbiter_test, ACandidateIsCheckedOnlyAgainstTheOthers) {
    auto a = connect("/a/out", "tcp");
    auto b = connect("/b/out", "tcp");  // a and b overlap, but that is not the candidate's business
    auto candidate = make("/c/out", "tcp+recv.portmonitor+constraint.e_c");
    const auto pairs = arbiter->overlaps(candidate.get());
    ASSERT_EQ(pairs.size(), 2u);
    EXPECT_EQ(pairs[0].first, "/a/out");
    EXPECT_EQ(pairs[0].second, "/c/out");
    EXPECT_EQ(pairs[1].first, "/b/out");
    EXPECT_EQ(pairs[1].second, "/c/out");
    EXPECT_TRUE(arbiter->uses_constraints(candidate.get()));
    EXPECT_FALSE(arbiter->uses_constraints());
}

TEST_F(Arbiter_test, AMemberThatLeftIsNoLongerChecked) {
    auto a = connect("/a/out", "tcp");
    auto b = connect("/b/out", "tcp");
    ASSERT_EQ(arbiter->overlaps().size(), 1u);
    b.reset();
    EXPECT_TRUE(arbiter->overlaps().empty());
}

}  // namespace
}  // namespace plexus::daemon::arbitration
