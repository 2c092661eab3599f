#include "expand.hpp"

#include <gtest/gtest.h>

#include "app_test_files.hpp"

namespace plexus::app {
namespace {

using test::variables;

TEST(Expand_test, ReplacesSetVariablesAndDefaults) {
    auto vars = variables({{"SPEED", "2"}, {"EMPTY", ""}});
    EXPECT_EQ(*expand_variables("--speed=${SPEED}", vars), "--speed=2");
    EXPECT_EQ(*expand_variables("${SPEED:-1}", vars), "2");
    EXPECT_EQ(*expand_variables("${SEED:-7}", vars), "7");
    EXPECT_EQ(*expand_variables("${EMPTY:-x}", vars), "x");  // as in the shell: empty takes the default
    EXPECT_EQ(*expand_variables("${NODE:-}", vars), "");
    EXPECT_EQ(*expand_variables("a ${SPEED}${SPEED} b", vars), "a 22 b");
}

TEST(Expand_test, LeavesLoneDollarsAndUnescapesDoubleDollar) {
    auto vars = variables({});
    EXPECT_EQ(*expand_variables("$5 and $", vars), "$5 and $");
    EXPECT_EQ(*expand_variables("$${HOME}", vars), "${HOME}");
    EXPECT_EQ(*expand_variables("{\"x\": 1}", vars), "{\"x\": 1}");
}

TEST(Expand_test, RefusesUnsetUnterminatedAndBadNames) {
    auto vars = variables({});
    auto unset = expand_variables("--seed ${SEED}", vars);
    ASSERT_FALSE(unset);
    EXPECT_NE(unset.error().message.find("variable SEED is not set"), std::string::npos);
    EXPECT_NE(unset.error().message.find("${SEED:-value}"), std::string::npos);
    EXPECT_FALSE(expand_variables("${SEED", vars));
    EXPECT_FALSE(expand_variables("${1X}", vars));
    EXPECT_FALSE(expand_variables("${A B}", vars));
    EXPECT_FALSE(expand_variables("${}", vars));
}

}  // namespace
}  // namespace plexus::app
