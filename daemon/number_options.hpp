#pragma once
// The check of the daemons' numeric options (plexusd, plexus-names), like the `plexus` CLI's
// (tools/cli/number_checks.hpp, which the daemon must not depend on): a value is taken only when
// it is a plain decimal number inside the option's range. CLI11's own conversion takes "-5" as
// 2^64-5 for an unsigned option, "0x10" as 16 and a leading 0 as octal, and aborts the program on
// a number past 64 bits. A refusal is one line naming the option, the range and the value: exit 2.
//
// Add it with Option::transform, not check: it also rewrites the value in plain decimal ("010" as
// "10"), so that CLI11 does not read it as octal.

#include <charconv>
#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace plexus::daemon {

/// A whole number from `least` to `most`, written in decimal digits only.
inline CLI::Validator whole_number(std::uint64_t least, std::uint64_t most) {
    const std::string range = std::to_string(least) + " to " + std::to_string(most);
    return CLI::Validator(
        [least, most, range](std::string& input) -> std::string {
            const std::string refusal = "expected a whole number from " + range + ", got '" + input + "'";
            // Digits only: no sign, no "0x", no exponent, no "nan" (which from_chars would read).
            if (input.empty() || input.find_first_not_of("0123456789") != std::string::npos)
                return refusal;
            std::uint64_t value = 0;
            const auto [end, error] = std::from_chars(input.data(), input.data() + input.size(), value);
            if (error != std::errc{} || end != input.data() + input.size() || value < least || value > most)
                return refusal;
            input = std::to_string(value);
            return {};
        },
        "[" + range + "]");
}

}  // namespace plexus::daemon
