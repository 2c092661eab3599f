#pragma once
// The carrier-string grammar of DESIGN.md:
//     carrier = base { "+" part }
//     part    = ("send." | "recv.") modifier-name   -- starts a clause on that side
//             | key [ "." value ]                   -- belongs to the last clause; split at the FIRST dot
// A key without a value is a flag. Several clauses on one side form a chain, in order.
// parse_carrier checks syntax; validate_carrier checks what this build supports.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

enum class Side { send, recv };

struct CarrierParam {
    std::string key;
    std::optional<std::string> value;  ///< empty for a flag
};

struct Clause {
    Side side = Side::recv;
    std::string modifier;  ///< "portmonitor", "priority", ...
    std::vector<CarrierParam> params;
    /// The value of `key`, or nullptr. A flag gives a pointer to an empty optional.
    const CarrierParam* find(std::string_view key) const;
};

struct Carrier {
    std::string base;             ///< "tcp", "udp", "mcast", "local"
    std::vector<Clause> clauses;  ///< in the order written; send and recv interleaved as given
    /// The canonical text (what parse_carrier would read back to the same Carrier).
    std::string text() const;
};

/// Parses the grammar. Positions are 0-based byte offsets into `text`.
/// Errors name the bad part: "empty carrier", "empty part at position 4",
/// "'threshold.0.8' at position 9 comes before any send./recv. clause", "empty modifier name in 'recv.'".
Result<Carrier> parse_carrier(std::string_view text);

/// Modifiers this build knows; later issues add to this.
struct CarrierSupport {
    std::vector<std::string> bases{"tcp", "udp", "mcast", "local"};
    /// Known base carriers that this build does not implement (refused as "not supported by this build").
    std::vector<std::string> unimplemented_bases{};
    /// Known modifiers this build does not implement.
    std::vector<std::string> unimplemented_modifiers{};
    /// Modifiers this build implements; a later issue moves a name here from the list above.
    std::vector<std::string> modifiers{"portmonitor", "priority"};
};

/// Checks a parsed carrier against what the build supports. Errors name the part:
/// "unknown carrier 'foo'", "unknown modifier 'recv.bogus'",
/// "modifier 'recv.portmonitor' is not supported by this build", "carrier 'udp' is not supported by this
/// build".
Status validate_carrier(const Carrier& carrier, const CarrierSupport& support = {});

}  // namespace plexus::proto
