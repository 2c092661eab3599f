// Constraints in isolation: the parser's errors name the exact position, the operators bind as
// not > and > or, and event names are whole tokens (the YARP substring defect: `e_ball` inside
// `e_ball_selected`).
#include "arbitration/constraint.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <set>
#include <string>
#include <vector>
#include "text_contains.hpp"

namespace plexus::daemon::arbitration {
namespace {

// The message of a constraint that must not parse; empty (and a failure) when it parses.
std::string parse_error(const std::string& text) {
    auto parsed = Constraint::parse(text);
    EXPECT_FALSE(parsed.ok()) << "'" << text << "' parsed";
    return parsed.ok() ? std::string() : parsed.error().message;
}

Constraint parse(const std::string& text) {
    auto parsed = Constraint::parse(text);
    EXPECT_TRUE(parsed.ok()) << "'" << text << "': " << (parsed.ok() ? "" : parsed.error().message);
    return parsed.ok() ? *parsed : *Constraint::parse("false");
}

bool value(const std::string& text, const std::set<std::string>& present) {
    return parse(text).evaluate(present);
}

TEST(Constraint_test, EmptyTextFailsAtPositionZero) {
    EXPECT_EQ(
        parse_error(""),
        "constraint '' at position 0: expected an event name, 'not', 'true', 'false' or '(', found the end");
}

TEST(Constraint_test, BlankTextFailsAtTheEnd) {
    // Only spaces: the first token is the end, after the blanks.
    EXPECT_TRUE(contains(parse_error("   "), "at position 3: expected an event name")) << parse_error("   ");
}

TEST(Constraint_test, MissingOperandAfterAndFailsAtTheEnd) {
    // "a and" is 5 characters: the operand is missing at position 5.
    EXPECT_EQ(
        parse_error("a and"),
        "constraint 'a and' at position 5: expected an event name, 'not', 'true', 'false' or '(', found "
        "the end");
}

TEST(Constraint_test, MissingOperandAfterOrFailsAtTheEnd) {
    EXPECT_TRUE(contains(parse_error("a or"), "at position 4: expected an event name"))
        << parse_error("a or");
}

TEST(Constraint_test, UnclosedParenthesisFailsAtTheEndAndNamesWhereItOpened) {
    EXPECT_EQ(
        parse_error("(a or b"),
        "constraint '(a or b' at position 7: expected ')' to close the '(' at position 0, found the end");
    // The innermost unclosed '(' is the one reported: here the outer one at 0 is left open
    // after the inner pair at 1..3 closed.
    EXPECT_TRUE(
        contains(parse_error("((a) and b"), "at position 10: expected ')' to close the '(' at position 0"))
        << parse_error("((a) and b");
    EXPECT_TRUE(contains(parse_error("a and (b or (c"),
                         "at position 14: expected ')' to close the '(' at position 12"))
        << parse_error("a and (b or (c");
}

TEST(Constraint_test, TwoNamesInARowFailAtTheSecond) {
    EXPECT_EQ(parse_error("a b"),
              "constraint 'a b' at position 2: expected 'and', 'or' or the end, found 'b'");
}

TEST(Constraint_test, UnknownCharacterFailsWhereItIs) {
    EXPECT_EQ(parse_error("a & b"), "constraint 'a & b' at position 2: unexpected character '&'");
    EXPECT_TRUE(contains(parse_error("a || b"), "at position 2: unexpected character '|'"))
        << parse_error("a || b");
    // '!' is not a spelling of `not`.
    EXPECT_TRUE(contains(parse_error("!a"), "at position 0: unexpected character '!'")) << parse_error("!a");
}

TEST(Constraint_test, LeadingOperatorFailsAtPositionZero) {
    EXPECT_EQ(
        parse_error("and a"),
        "constraint 'and a' at position 0: expected an event name, 'not', 'true', 'false' or '(', found "
        "'and'");
    EXPECT_TRUE(contains(parse_error("or a"), "at position 0: expected an event name"))
        << parse_error("or a");
}

TEST(Constraint_test, NotWithoutOperandFailsAtTheEnd) {
    EXPECT_EQ(
        parse_error("not"),
        "constraint 'not' at position 3: expected an event name, 'not', 'true', 'false' or '(', found the "
        "end");
    EXPECT_TRUE(contains(parse_error("a and not"), "at position 9:")) << parse_error("a and not");
}

TEST(Constraint_test, LoneClosingParenthesisFailsAtPositionZero) {
    EXPECT_EQ(
        parse_error(")"),
        "constraint ')' at position 0: expected an event name, 'not', 'true', 'false' or '(', found ')'");
    // A ')' too many after a complete expression: the expression ended, so the ')' is unexpected.
    EXPECT_EQ(parse_error("(a))"),
              "constraint '(a))' at position 3: expected 'and', 'or' or the end, found ')'");
}

TEST(Constraint_test, EmptyParenthesesFailAtTheClosingOne) {
    EXPECT_TRUE(contains(parse_error("()"), "at position 1: expected an event name")) << parse_error("()");
}

TEST(Constraint_test, DoubledOperatorFailsAtTheSecond) {
    EXPECT_TRUE(contains(parse_error("a and or b"), "at position 6: expected an event name"))
        << parse_error("a and or b");
}

TEST(Constraint_test, TrueAndFalseAreConstants) {
    EXPECT_TRUE(value("true", {}));
    EXPECT_FALSE(value("false", {}));
    // They are keywords, not events: an event called "true" being absent does not matter.
    EXPECT_TRUE(parse("true").events().empty());
    EXPECT_FALSE(value("false", {"false"}));
}

TEST(Constraint_test, AnEventNameStandsForItsPresence) {
    EXPECT_TRUE(value("e_ok", {"e_ok"}));
    EXPECT_FALSE(value("e_ok", {}));
    EXPECT_FALSE(value("e_ok", {"e_other"}));
}

TEST(Constraint_test, NotBindsTighterThanAnd) {
    // "not a and b" is (not a) and b. Read as not (a and b) it would be true with nothing present.
    EXPECT_FALSE(value("not a and b", {}));
    EXPECT_TRUE(value("not a and b", {"b"}));
    EXPECT_FALSE(value("not a and b", {"a", "b"}));
}

TEST(Constraint_test, AndBindsTighterThanOr) {
    // "a or b and c" is a or (b and c). Read as (a or b) and c it would be false with only a.
    EXPECT_TRUE(value("a or b and c", {"a"}));
    EXPECT_FALSE(value("a or b and c", {"b"}));
    EXPECT_TRUE(value("a or b and c", {"b", "c"}));
    // "a and b or c" is (a and b) or c. Read as a and (b or c) it would be false with only c.
    EXPECT_TRUE(value("a and b or c", {"c"}));
    EXPECT_FALSE(value("a and b or c", {"a"}));
}

TEST(Constraint_test, NotBindsTighterThanOr) {
    // "not a or b" is (not a) or b: true with a and b; as not (a or b) it would be false.
    EXPECT_TRUE(value("not a or b", {"a", "b"}));
    EXPECT_FALSE(value("not a or b", {"a"}));
}

TEST(Constraint_test, ParenthesesOverridePrecedence) {
    // (a or b) and c: false with only a, where a or (b and c) is true.
    EXPECT_FALSE(value("(a or b) and c", {"a"}));
    EXPECT_TRUE(value("(a or b) and c", {"a", "c"}));
    // not (a and b): true with only a, where (not a) and b is false.
    EXPECT_TRUE(value("not (a and b)", {"a"}));
    EXPECT_FALSE(value("not (a and b)", {"a", "b"}));
    EXPECT_TRUE(value("((a))", {"a"}));
}

TEST(Constraint_test, NotNestsAndCancels) {
    EXPECT_TRUE(value("not not a", {"a"}));
    EXPECT_FALSE(value("not not a", {}));
    EXPECT_TRUE(value("not not not a", {}));
}

TEST(Constraint_test, SpacesAreOptionalAroundParenthesesAndTabsCount) {
    // "(a)and(not(b))" needs no spaces: parentheses end names as spaces do.
    EXPECT_TRUE(value("(a)and(not(b))", {"a"}));
    EXPECT_FALSE(value("(a)and(not(b))", {"a", "b"}));
    EXPECT_TRUE(value("a\tand\tb", {"a", "b"}));
}

TEST(Constraint_test, KeywordsAreWholeWordsSoNamesMayStartWithThem) {
    // "nota", "android" and "order" are event names, not `not a`, `and ...`, `or ...`.
    EXPECT_EQ(parse("nota and android or order").events(),
              (std::vector<std::string>{"android", "nota", "order"}));
    EXPECT_TRUE(value("nota", {"nota"}));
    EXPECT_FALSE(value("nota", {"a"}));
}

TEST(Constraint_test, EventNamesMayHoldDotsColonsSlashesAndDashes) {
    EXPECT_TRUE(value("e.a:b/c-d and x_1", {"e.a:b/c-d", "x_1"}));
    EXPECT_FALSE(value("e.a:b/c-d", {"e.a"}));
}

TEST(Constraint_test, AShortNameIsFalseWhenOnlyALongerNameStartingWithItIsPresent) {
    // YARP substitutes event names into the text, so e_ball matched inside e_ball_selected.
    EXPECT_FALSE(value("e_ball", {"e_ball_selected"}));
    EXPECT_TRUE(value("e_ball", {"e_ball", "e_ball_selected"}));
}

TEST(Constraint_test, ALongNameIsFalseWhenOnlyAShorterPrefixOfItIsPresent) {
    EXPECT_FALSE(value("e_ball_selected", {"e_ball"}));
    EXPECT_TRUE(value("e_ball_selected", {"e_ball_selected"}));
    // Both in one expression: each answers for itself.
    EXPECT_TRUE(value("e_ball and not e_ball_selected", {"e_ball"}));
    EXPECT_FALSE(value("e_ball and not e_ball_selected", {"e_ball_selected"}));
}

TEST(Constraint_test, EventsAreSortedAndListedOnce) {
    const auto constraint = parse("zeta or (alpha and not zeta) or mid and alpha or true");
    EXPECT_EQ(constraint.events(), (std::vector<std::string>{"alpha", "mid", "zeta"}));
    EXPECT_EQ(constraint.text(), "zeta or (alpha and not zeta) or mid and alpha or true");
}

std::string repeat(const std::string& part, std::size_t times) {
    std::string text;
    for (std::size_t i = 0; i < times; ++i)
        text += part;
    return text;
}

TEST(Constraint_test, SixtyFourNestedLevelsAreFine) {
    EXPECT_TRUE(value(repeat("(", 64) + "a" + repeat(")", 64), {"a"}));
    EXPECT_TRUE(value(repeat("not ", 64) + "a", {"a"}));  // an even number of nots
    EXPECT_TRUE(value(repeat("not (", 32) + "a" + repeat(")", 32), {"a"}));
}

TEST(Constraint_test, DeeperNestingIsRefusedWhereItGoesTooDeep) {
    // The parser recurses for each '(' and 'not': the 65th level is refused, at its position.
    EXPECT_TRUE(contains(parse_error(repeat("(", 65) + "a" + repeat(")", 65)),
                         "at position 64: expected at most 64 nested '(' and 'not', found '('"));
    // "not " is 4 characters: the 65th starts at 256.
    EXPECT_TRUE(contains(parse_error(repeat("not ", 65) + "a"),
                         "at position 256: expected at most 64 nested '(' and 'not', found 'not'"));
}

TEST(Constraint_test, ParenthesesSideBySideDoNotAddUp) {
    // 100 groups one after the other are one level deep each.
    EXPECT_TRUE(value("(a)" + repeat(" and (not (b))", 100), {"a"}));
}

TEST(Constraint_test, AHugeConstraintIsAnErrorNotAStackOverflow) {
    // 100 000 nested '(' overflowed the daemon's stack before the limits; a carrier or a script
    // can send that.
    EXPECT_TRUE(contains(parse_error(repeat("(", 100000) + "a" + repeat(")", 100000)),
                         "constraint of 200001 characters: longer than the limit of 4096"));
    EXPECT_TRUE(contains(parse_error("a" + repeat(" and a", 1000000)), "longer than the limit of 4096"));
}

TEST(Constraint_test, TheLengthLimitIsInclusive) {
    // A chain as long as allowed still parses and evaluates: "a" + 819 times " or b" = 4096.
    const std::string longest = "a" + repeat(" or b", 819);
    ASSERT_EQ(longest.size(), 4096u);
    EXPECT_TRUE(value(longest, {"b"}));
    EXPECT_TRUE(contains(parse_error(longest + "c"), "constraint of 4097 characters"));
}

TEST(Constraint_test, EvaluateAsksTheCallbackForEachNameItNeeds) {
    const auto constraint = parse("e_a and not e_b");
    std::vector<std::string> asked;
    const bool result = constraint.evaluate([&](const std::string& name) {
        asked.push_back(name);
        return name == "e_a";
    });
    EXPECT_TRUE(result);
    EXPECT_EQ(asked, (std::vector<std::string>{"e_a", "e_b"}));
}

TEST(Constraint_test, CopiesEvaluateLikeTheOriginal) {
    // The tree is shared between copies; a copy must outlive the original.
    std::optional<Constraint> copy;
    {
        const auto original = parse("a and not b");
        copy = original;
    }
    EXPECT_TRUE(copy->evaluate(std::set<std::string>{"a"}));
    EXPECT_FALSE(copy->evaluate(std::set<std::string>{"a", "b"}));
}

}  // namespace
}  // namespace plexus::daemon::arbitration
