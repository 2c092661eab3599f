#include "number_checks.hpp"

#include <charconv>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "plexus/proto/whole_number.hpp"

namespace plexus::cli {

namespace {

/// 0.05, 3600, 31536000: no exponent and no trailing zeros for the ranges written here.
std::string plain(double value) {
    std::ostringstream out;
    out << std::setprecision(15) << value;
    return out.str();
}

std::string range_text(const std::string& least, const std::string& most) {
    return least + " to " + most;
}

}  // namespace

CLI::Validator whole_number(std::uint64_t least, std::uint64_t most) {
    const std::string range = range_text(std::to_string(least), std::to_string(most));
    return CLI::Validator(
        [least, most, range](std::string& input) -> std::string {
            const auto value = proto::parse_whole_number(input, least, most);
            if (!value)
                return "expected a whole number from " + range + ", got '" + input + "'";
            input = std::to_string(*value);  // "010" is ten, not CLI11's octal eight
            return {};
        },
        "[" + range + "]");
}

CLI::Validator seconds(double least, double most) {
    const std::string range = range_text(plain(least), plain(most));
    return CLI::Validator(
        [least, most, range](std::string& input) -> std::string {
            double value = 0;
            const auto [end, error] = std::from_chars(input.data(), input.data() + input.size(), value);
            const std::string refusal =
                "expected a number of seconds from " + range + ", got '" + input + "'";
            const bool whole = !input.empty() && error == std::errc{} && end == input.data() + input.size();
            if (!whole)
                return refusal;
            // from_chars reads "nan" and "inf" as numbers, and every comparison with NaN is false:
            // a range check alone lets it through (a redraw loop without pause, a wait for ever).
            if (!std::isfinite(value))
                return refusal + ", not a finite number";
            if (value < least || value > most)
                return refusal;
            return {};
        },
        "[" + range + "]");
}

}  // namespace plexus::cli
