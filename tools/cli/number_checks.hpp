#pragma once
// The checks of every numeric option of `plexus`, written once: a value is taken only when it is
// a plain decimal number inside the option's range. NaN passes CLI11's own Range (every comparison
// with it is false), its unsigned conversion turns -5 into 2^64-5, its PositiveNumber prints
// DBL_MAX's 309 digits as the upper bound, and a duration past the steady clock's range wraps.
// Each refusal is one line naming the option, the accepted range and the value given, exit 2.
//
// Add them with Option::transform, not check: whole_number also rewrites the value in plain
// decimal ("010" as "10"), because CLI11 reads a leading 0 as octal.

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace plexus::cli {

/// The most any count option takes (messages, redraws, queue length). A queue holds at most its
/// byte bound (8 MiB by default) whatever its length, so a longer one would change nothing.
inline constexpr std::uint64_t most_count = 1'000'000'000;
/// The longest duration any option takes, in seconds: a year. Far below where a steady-clock
/// deadline overflows (about 292 years of nanoseconds).
inline constexpr double most_seconds = 365.0 * 24 * 3600;

/// A whole number from `least` to `most`, written in decimal digits only.
CLI::Validator whole_number(std::uint64_t least, std::uint64_t most);
/// A finite number of seconds from `least` to `most`: NaN, infinities and text are refused.
CLI::Validator seconds(double least, double most);

}  // namespace plexus::cli
