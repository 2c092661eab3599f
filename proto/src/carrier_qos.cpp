// The `qos.dscp.N` and `qos.prio.N` parts of a carrier (DESIGN.md, "Monitors, second pass").
#include <array>
#include <charconv>

#include "plexus/proto/carrier.hpp"

namespace plexus::proto {

namespace {

struct Setting {
    std::string_view name;
    int highest;
    std::optional<int> Qos::*field;
};

constexpr std::array<Setting, 2> settings{{
    {"dscp", 63, &Qos::dscp},
    {"prio", 7, &Qos::prio},
}};

}  // namespace

Status parse_qos_part(std::string_view setting_and_value, Qos& qos) {
    const std::size_t dot = setting_and_value.find('.');
    const std::string_view name = setting_and_value.substr(0, dot);
    const Setting* setting = nullptr;
    for (const auto& known : settings) {
        if (known.name == name)
            setting = &known;
    }
    if (setting == nullptr) {
        return Error{"unknown qos setting 'qos." + std::string(setting_and_value) +
                     "' (use qos.dscp.N with N 0-63, or qos.prio.N with N 0-7)"};
    }
    const std::string full = "qos." + std::string(name);
    const std::string range = "0-" + std::to_string(setting->highest);
    if (dot == std::string_view::npos || dot + 1 == setting_and_value.size())
        return Error{"'" + full + "' needs a value: '" + full + ".N' with N " + range};
    const std::string_view digits = setting_and_value.substr(dot + 1);
    int number = 0;
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
    // from_chars takes a leading '-': "-1" is a number, only out of range.
    if (error == std::errc::invalid_argument || end != digits.data() + digits.size())
        return Error{full + " value '" + std::string(digits) + "' is not a whole number (" + range + ")"};
    if (error == std::errc::result_out_of_range || number < 0 || number > setting->highest)
        return Error{full + " value '" + std::string(digits) + "' is out of range (" + range + ")"};
    if (qos.*(setting->field))
        return Error{"duplicate '" + full + "'"};
    qos.*(setting->field) = number;
    return Ok{};
}

int socket_priority_for_dscp(int dscp) {
    // Linux's own mapping (IP_TOS sets the priority from the old TOS bits) ignores the class:
    // EF (46) would land in pfifo_fast's middle band and CS6 (48) with best effort. So the class
    // selector (the top three bits) picks a TC_PRIO_* value instead. pfifo_fast's default priomap
    // sends 6 and 7 to band 0, 0 and 4 to band 1, 1 and 2 to band 2. TC_PRIO_CONTROL (7) needs
    // CAP_NET_ADMIN, so the top classes stop at TC_PRIO_INTERACTIVE (6), which needs nothing.
    constexpr int best_effort = 0;
    constexpr int bulk = 2;
    constexpr int interactive_bulk = 4;
    constexpr int interactive = 6;
    constexpr std::array<int, 8> by_class{
        best_effort,       // CS0: default
        bulk,              // CS1, AF1x: lower effort, bulk
        best_effort,       // CS2, AF2x
        interactive_bulk,  // CS3, AF3x: streaming
        interactive_bulk,  // CS4, AF4x
        interactive,       // CS5, EF, VA: real-time
        interactive,       // CS6: network control
        interactive,       // CS7
    };
    return by_class.at(static_cast<std::size_t>((dscp >> 3) & 7));
}

}  // namespace plexus::proto
