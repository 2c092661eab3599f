// What a carrier string says about arbitration: configure_member reads the constraint./aux keys
// of recv.portmonitor and the recv.priority clause, and refuses anything misplaced or malformed
// with a message that names the part.
#include "arbitration/carrier_rules.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "arbitration/clock.hpp"
#include "plexus/proto/carrier.hpp"
#include "text_contains.hpp"

namespace plexus::daemon::arbitration {
namespace {

proto::Carrier carrier(const std::string& text) {
    auto parsed = proto::parse_carrier(text);
    EXPECT_TRUE(parsed.ok()) << text << ": " << (parsed.ok() ? "" : parsed.error().message);
    return parsed.ok() ? *parsed : proto::Carrier{};
}

struct ConfigureMember_test : ::testing::Test {
    ManualClock clock;
    std::shared_ptr<Arbiter> arbiter = std::make_shared<Arbiter>(clock);
    Member member{arbiter, "/face/out"};

    proto::Status configure(const std::string& text) { return configure_member(member, carrier(text)); }
    std::string refusal(const proto::Carrier& given) {
        auto status = configure_member(member, given);
        EXPECT_FALSE(status.ok()) << given.text() << " was accepted";
        return status.ok() ? std::string() : status.error().message;
    }
    std::string refusal(const std::string& text) { return refusal(carrier(text)); }
};

TEST_F(ConfigureMember_test, APlainCarrierLeavesTheMemberTrivial) {
    ASSERT_TRUE(configure("tcp").ok());
    EXPECT_FALSE(member.constraint.has_value());
    EXPECT_FALSE(member.priority.has_value());
    EXPECT_FALSE(member.stimulus.has_value());
    EXPECT_FALSE(member.aux);
    EXPECT_TRUE(member.trivial());
}

TEST_F(ConfigureMember_test, AScriptsOwnKeysAreNotArbitration) {
    ASSERT_TRUE(configure("tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8").ok());
    EXPECT_TRUE(member.trivial());
}

TEST_F(ConfigureMember_test, ReadsTheConstraintOfARecvPortmonitor) {
    auto status = configure(
        "tcp+recv.portmonitor+type.lua+file.certainty+constraint.e_template_ok and not e_particle_ok");
    ASSERT_TRUE(status.ok()) << status.error().message;
    ASSERT_TRUE(member.constraint.has_value());
    EXPECT_EQ(member.constraint->text(), "e_template_ok and not e_particle_ok");
    EXPECT_EQ(member.constraint->events(), (std::vector<std::string>{"e_particle_ok", "e_template_ok"}));
    EXPECT_FALSE(member.trivial());
}

TEST_F(ConfigureMember_test, AConstraintMayHoldDotsBecauseOnlyTheFirstDotSplits) {
    ASSERT_TRUE(configure("tcp+recv.portmonitor+constraint.e.ok").ok());
    ASSERT_TRUE(member.constraint.has_value());
    EXPECT_EQ(member.constraint->events(), std::vector<std::string>{"e.ok"});
}

TEST_F(ConfigureMember_test, ABadConstraintIsRefusedWithItsPosition) {
    // The position counts in the constraint, not in the carrier string.
    EXPECT_EQ(
        refusal("tcp+recv.portmonitor+constraint.a and"),
        "constraint 'a and' at position 5: expected an event name, 'not', 'true', 'false' or '(', found "
        "the end");
    EXPECT_TRUE(contains(refusal("tcp+recv.portmonitor+constraint.(a)and"), "at position 6"));
    EXPECT_TRUE(contains(refusal("tcp+recv.portmonitor+constraint.e_x and (e_y or"),
                         "at position 15: expected an event name"));
}

TEST_F(ConfigureMember_test, AConstraintKeyWithoutValueIsRefused) {
    EXPECT_TRUE(contains(refusal("tcp+recv.portmonitor+constraint"), "at position 0"));
}

TEST_F(ConfigureMember_test, SendPriorityIsRefusedPointingToRecv) {
    const auto message = refusal("tcp+send.priority+tc.1");
    EXPECT_TRUE(contains(message, "send.priority")) << message;
    EXPECT_TRUE(contains(message, "recv.priority")) << message;
}

TEST_F(ConfigureMember_test, AuxOnTheSendSideIsRefused) {
    const auto aux = refusal("tcp+send.portmonitor+type.lua+file.codec+aux");
    EXPECT_TRUE(contains(aux, "'aux' in a send.portmonitor clause")) << aux;
}

TEST_F(ConfigureMember_test, ASendSideConstraintIsARouteConstraintNotTheInputPorts) {
    const auto parsed = carrier("tcp+send.portmonitor+constraint.e_a and not e_b");
    Member member{arbiter, "/source"};
    ASSERT_TRUE(configure_member(member, parsed).ok());
    EXPECT_FALSE(member.constraint.has_value()) << "the input port's arbitration must not see it";
    const auto route = route_constraint(parsed);
    ASSERT_TRUE(route.ok()) << route.error().message;
    ASSERT_TRUE(route->has_value());
    EXPECT_EQ((*route)->text(), "e_a and not e_b");
    EXPECT_FALSE(route_constraint(carrier("tcp+recv.portmonitor+constraint.e_a"))->has_value());
    const auto bad = route_constraint(carrier("tcp+send.portmonitor+constraint.e_a and"));
    ASSERT_FALSE(bad.ok());
    EXPECT_TRUE(contains(bad.error().message, "at position")) << bad.error().message;
}

TEST_F(ConfigureMember_test, TwoConstraintsAreRefused) {
    // In one clause parse_carrier already refuses the duplicate key; configure_member refuses it
    // too, for a carrier made some other way.
    auto one_clause = carrier("tcp+recv.portmonitor+constraint.e_a");
    one_clause.clauses[0].params.push_back({"constraint", "e_b"});
    const auto same_clause = refusal(one_clause);
    EXPECT_TRUE(contains(same_clause, "two constraints on one connection ('e_a' and 'e_b')")) << same_clause;

    Member other{arbiter, "/other/out"};
    auto two_clauses = configure_member(
        other, carrier("tcp+recv.portmonitor+constraint.e_a+recv.portmonitor+constraint.e_b"));
    ASSERT_FALSE(two_clauses.ok());
    EXPECT_TRUE(contains(two_clauses.error().message, "two constraints")) << two_clauses.error().message;
}

TEST_F(ConfigureMember_test, TwoPriorityClausesAreRefused) {
    EXPECT_TRUE(contains(refusal("tcp+recv.priority+tc.1+recv.priority+tc.2"), "two recv.priority clauses"));
}

TEST_F(ConfigureMember_test, ReadsThePriorityClause) {
    ASSERT_TRUE(configure("tcp+recv.priority+tc.0.5+tr.1+st.0.5+bs.2+ex./face/out:-1").ok());
    ASSERT_TRUE(member.priority.has_value());
    EXPECT_EQ(member.priority->tc, 0.5);
    EXPECT_EQ(member.priority->tr, 1.0);
    EXPECT_EQ(member.priority->st, 0.5);
    EXPECT_EQ(member.priority->bs, 2.0);
    using Weights = std::vector<std::pair<std::string, double>>;
    EXPECT_EQ(member.priority->ex, (Weights{{"/face/out", -1.0}}));
    EXPECT_TRUE(member.stimulus.has_value());
    EXPECT_FALSE(member.aux);
    EXPECT_FALSE(member.trivial());
}

TEST_F(ConfigureMember_test, UnknownPriorityKeyIsRefusedNamingIt) {
    const auto message = refusal("tcp+recv.priority+zz.1");
    EXPECT_TRUE(contains(message, "'zz'")) << message;
}

TEST_F(ConfigureMember_test, BadPriorityNumbersAreRefused) {
    EXPECT_EQ(refusal("tcp+recv.priority+tc.abc"), "priority key tc.abc: expected a number");
    EXPECT_EQ(refusal("tcp+recv.priority+tc.0"), "priority tc must be > 0 seconds");
}

TEST_F(ConfigureMember_test, ExWithoutAColonIsRefused) {
    const auto message = refusal("tcp+recv.priority+ex./face/out");
    EXPECT_TRUE(contains(message, "is not SOURCE:WEIGHT")) << message;
}

TEST_F(ConfigureMember_test, ExWithAnInvalidPortNameIsRefused) {
    const auto message = refusal("tcp+recv.priority+ex.face:-1");
    EXPECT_TRUE(contains(message, "priority ex.face:-1: port name")) << message;
    EXPECT_TRUE(contains(message, "must start with '/'")) << message;
}

TEST_F(ConfigureMember_test, ExPortNamesMayHoldColonsTheLastOneSplits) {
    ASSERT_TRUE(configure("tcp+recv.priority+ex./face:o:-1").ok());
    ASSERT_TRUE(member.priority.has_value());
    ASSERT_EQ(member.priority->ex.size(), 1u);
    EXPECT_EQ(member.priority->ex[0].first, "/face:o");
    EXPECT_EQ(member.priority->ex[0].second, -1.0);
}

TEST_F(ConfigureMember_test, AuxOnPriorityMakesAnAuxiliaryStimulatedMember) {
    ASSERT_TRUE(configure("tcp+recv.priority+aux+ex./object/out:1").ok());
    EXPECT_TRUE(member.aux);
    ASSERT_TRUE(member.priority.has_value());
    EXPECT_TRUE(member.priority->aux);
    EXPECT_TRUE(member.stimulus.has_value());
}

TEST_F(ConfigureMember_test, AuxOnPortmonitorMakesAnAuxiliaryMemberWithoutStimulation) {
    ASSERT_TRUE(configure("tcp+recv.portmonitor+type.lua+file.detector+aux").ok());
    EXPECT_TRUE(member.aux);
    EXPECT_FALSE(member.priority.has_value());
    EXPECT_FALSE(member.trivial());
}

TEST_F(ConfigureMember_test, AuxOnPortmonitorAlsoCountsForALaterPriorityClause) {
    ASSERT_TRUE(configure("tcp+recv.portmonitor+aux+recv.priority+tc.0.5").ok());
    EXPECT_TRUE(member.aux);
    ASSERT_TRUE(member.priority.has_value());
    EXPECT_FALSE(member.priority->aux);  // the clause itself did not say it; the member is still aux
}

TEST_F(ConfigureMember_test, AuxTakesNoValue) {
    EXPECT_TRUE(contains(refusal("tcp+recv.portmonitor+aux.1"), "'aux' is a flag"));
    EXPECT_TRUE(contains(refusal("tcp+recv.priority+aux.yes"), "'aux' is a flag"));
}

TEST_F(ConfigureMember_test, ConstraintAndPriorityTogether) {
    auto status = configure("tcp+recv.priority+tc.0.5+recv.portmonitor+constraint.e_ok or not e_off");
    ASSERT_TRUE(status.ok()) << status.error().message;
    EXPECT_TRUE(member.constraint.has_value());
    EXPECT_TRUE(member.priority.has_value());
}

TEST(ArbitrationOnly_test, APortmonitorWithOnlyArbitrationKeysNeedsNoScript) {
    EXPECT_TRUE(arbitration_only(carrier("tcp+recv.portmonitor+constraint.e_a").clauses[0]));
    EXPECT_TRUE(arbitration_only(carrier("tcp+recv.portmonitor+aux").clauses[0]));
    EXPECT_FALSE(arbitration_only(carrier("tcp+recv.portmonitor+type.lua+file.x+constraint.e_a").clauses[0]));
    EXPECT_FALSE(arbitration_only(carrier("tcp+recv.portmonitor+type.lua").clauses[0]));
    EXPECT_FALSE(arbitration_only(carrier("tcp+recv.priority+aux").clauses[0]));
}

}  // namespace
}  // namespace plexus::daemon::arbitration
