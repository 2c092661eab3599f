#pragma once
// Pure: a whole number as the command lines take one (plexus, plexusd, plexus-names).

#include <charconv>
#include <cstdint>
#include <optional>
#include <string_view>

namespace plexus::proto {

/// `text` as a whole number from `least` to `most`, written in decimal digits only: no sign, no
/// "0x", no exponent, no "nan" (CLI11's own conversion takes "-5" as 2^64-5 for an unsigned
/// option, "0x10" as 16 and a leading 0 as octal). nullopt when it is anything else.
inline std::optional<std::uint64_t> parse_whole_number(std::string_view text, std::uint64_t least,
                                                       std::uint64_t most) {
    if (text.empty() || text.find_first_not_of("0123456789") != std::string_view::npos)
        return std::nullopt;
    std::uint64_t value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (error != std::errc{} || end != text.data() + text.size() || value < least || value > most)
        return std::nullopt;
    return value;
}

}  // namespace plexus::proto
