#pragma once
// The carrier-string grammar of DESIGN.md:
//     carrier = base { "+" part }
//     part    = ("send." | "recv.") modifier-name   -- starts a clause on that side
//             | key [ "." value ]                   -- belongs to the last clause; split at the FIRST dot
//             | "qos." setting "." number           -- the connection's priority, anywhere (carrier_qos.cpp)
// A key without a value is a flag. Several clauses on one side form a chain, in order. `qos` is
// never a clause key: `qos.dscp.N` and `qos.prio.N` belong to the connection wherever they stand.
// parse_carrier checks syntax; validate_carrier checks what this build supports.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

enum class Side { send, recv };

/// "send" or "recv", as the carrier string writes a side.
const char* side_name(Side side);

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

/// The connection's priority (`qos.dscp.N`, `qos.prio.N`); unset means 0, nothing asked.
struct Qos {
    std::optional<int> dscp;  ///< 0-63: the DiffServ code point its packets carry
    std::optional<int> prio;  ///< 0-7, higher first: the order the daemon serves ready queues in
    bool operator==(const Qos&) const = default;
};

/// Reads one `qos.SETTING.N` part's "SETTING.N" into `qos`. Errors name the part and the range:
/// "qos.dscp value '64' is out of range (0-63)", "unknown qos setting 'qos.foo' (use qos.dscp.N or
/// qos.prio.N)", "duplicate 'qos.prio'".
Status parse_qos_part(std::string_view setting_and_value, Qos& qos);
/// The kernel's socket priority (SO_PRIORITY) that matches a DSCP: its class selector mapped to a
/// Linux TC_PRIO_* value, so that pfifo_fast puts EF, CS5-CS7 into its first band (carrier_qos.cpp).
int socket_priority_for_dscp(int dscp);

struct Carrier {
    std::string base;             ///< "tcp", "udp", "mcast", "local"
    std::vector<Clause> clauses;  ///< in the order written; send and recv interleaved as given
    Qos qos;                      ///< written right after the base in text()
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
