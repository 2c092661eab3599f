// The checks behind every numeric option of `plexus`, in-process: the bounds are inclusive, a
// value is read in decimal whatever its leading zeros, and a refusal names the option.
#include "number_checks.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace plexus::cli {
namespace {

/// Parses `plexus --value VALUE` with the check under test; the error message, or nullopt.
template <typename T>
std::optional<std::string> parse(T& target, const CLI::Validator& check, const std::string& value) {
    CLI::App app;
    app.add_option("--value", target)->transform(check);
    std::vector<std::string> args = {"--value=" + value};
    try {
        app.parse(args);
    } catch (const CLI::ParseError& e) {
        return std::string(e.what());
    }
    return std::nullopt;
}

TEST(WholeNumber_test, TakesBothBoundsAndRefusesJustPast) {
    long value = 0;
    EXPECT_EQ(parse(value, whole_number(1, 10), "1"), std::nullopt);
    EXPECT_EQ(value, 1);
    EXPECT_EQ(parse(value, whole_number(1, 10), "10"), std::nullopt);
    EXPECT_EQ(value, 10);
    EXPECT_EQ(parse(value, whole_number(1, 10), "11"),
              "--value: expected a whole number from 1 to 10, got '11'");
    EXPECT_NE(parse(value, whole_number(1, 10), "0"), std::nullopt);
}

TEST(WholeNumber_test, ReadsLeadingZerosAsDecimalNotOctal) {
    long value = 0;
    EXPECT_EQ(parse(value, whole_number(1, 100), "010"), std::nullopt);
    EXPECT_EQ(value, 10);
}

TEST(WholeNumber_test, RefusesWhatCli11WouldWrapOrReadAsHex) {
    std::size_t value = 0;
    for (const char* text : {"-5", "+5", "0x10", "18446744073709551616", " 5", "5 "})
        EXPECT_NE(parse(value, whole_number(1, 100), text), std::nullopt) << text;
}

TEST(Seconds_test, TakesFractionsInRangeAndRefusesNonFiniteByName) {
    double value = 0;
    EXPECT_EQ(parse(value, seconds(0.05, 3600), "0.05"), std::nullopt);
    EXPECT_DOUBLE_EQ(value, 0.05);
    EXPECT_EQ(parse(value, seconds(0.05, 3600), "1e3"), std::nullopt);
    EXPECT_DOUBLE_EQ(value, 1000);
    EXPECT_EQ(parse(value, seconds(0.05, 3600), "nan"),
              "--value: expected a number of seconds from 0.05 to 3600, got 'nan', not a finite number");
    EXPECT_NE(parse(value, seconds(0.05, 3600), "0.04"), std::nullopt);
    EXPECT_NE(parse(value, seconds(0.05, 3600), "0x10"), std::nullopt);
}

}  // namespace
}  // namespace plexus::cli
