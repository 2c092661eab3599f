#pragma once
// The check of the daemons' numeric options (plexusd, plexus-names), like the `plexus` CLI's
// (tools/cli/number_checks.hpp, which the daemon must not depend on): a value is taken only when
// it is a plain decimal number inside the option's range. CLI11's own conversion takes "-5" as
// 2^64-5 for an unsigned option, "0x10" as 16 and a leading 0 as octal, and aborts the program on
// a number past 64 bits. A refusal is one line naming the option, the range and the value: exit 2.
//
// Add it with Option::transform, not check: it also rewrites the value in plain decimal ("010" as
// "10"), so that CLI11 does not read it as octal.

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "plexus/proto/whole_number.hpp"

namespace plexus::daemon {

/// A whole number from `least` to `most`, written in decimal digits only.
inline CLI::Validator whole_number(std::uint64_t least, std::uint64_t most) {
    const std::string range = std::to_string(least) + " to " + std::to_string(most);
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

}  // namespace plexus::daemon
