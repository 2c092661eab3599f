#include "plexus/proto/carrier.hpp"

#include <algorithm>

namespace plexus::proto {

namespace {

bool is_name_char(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}

std::string show_carrier_char(char c) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte <= 0x20 || byte >= 0x7f) {
        constexpr std::string_view digits = "0123456789abcdef";
        return {'\\', 'x', digits[byte >> 4], digits[byte & 0x0f]};
    }
    // Braces would pick the initializer-list constructor and give "\x01" followed by c.
    return std::string(1, c);  // NOLINT(modernize-return-braced-init-list)
}

std::string in_quotes(std::string_view text) {
    return "'" + std::string(text) + "'";
}

std::string at(std::size_t position) {
    return " at position " + std::to_string(position);
}

// Base carriers, modifier names and keys are plain names; values may hold anything but '+'.
std::optional<std::string> name_error(std::string_view kind, std::string_view name, std::size_t position) {
    for (std::size_t i = 0; i < name.size(); ++i) {
        if (!is_name_char(name[i])) {
            return "character '" + show_carrier_char(name[i]) + "'" + at(position + i) +
                   " is not allowed in " + std::string(kind) + " " + in_quotes(name) +
                   " (use A-Z a-z 0-9 _ -)";
        }
    }
    return std::nullopt;
}

bool contains(const std::vector<std::string>& names, std::string_view name) {
    return std::find(names.begin(), names.end(), name) != names.end();
}

struct Part {
    std::string_view text;
    std::size_t position;
};

}  // namespace

const char* side_name(Side side) {
    return side == Side::send ? "send" : "recv";
}

const CarrierParam* Clause::find(std::string_view key) const {
    for (const auto& param : params) {
        if (param.key == key) {
            return &param;
        }
    }
    return nullptr;
}

std::string Carrier::text() const {
    std::string out = base;
    if (qos.dscp)
        out += "+qos.dscp." + std::to_string(*qos.dscp);
    if (qos.prio)
        out += "+qos.prio." + std::to_string(*qos.prio);
    for (const auto& clause : clauses) {
        out += '+';
        out += side_name(clause.side);
        out += '.';
        out += clause.modifier;
        for (const auto& param : clause.params) {
            out += '+';
            out += param.key;
            if (param.value) {
                out += '.';
                out += *param.value;
            }
        }
    }
    return out;
}

Result<Carrier> parse_carrier(std::string_view text) {
    if (text.empty()) {
        return Error{"empty carrier"};
    }
    // Control characters are a mistake. Spaces are allowed only inside values, where a
    // constraint needs them ("constraint.e_a and not e_b"); in names they are refused below.
    for (std::size_t i = 0; i < text.size(); ++i) {
        const auto byte = static_cast<unsigned char>(text[i]);
        if (byte < 0x20 || byte >= 0x7f) {
            return Error{"character '" + show_carrier_char(text[i]) + "'" + at(i) +
                         " is not allowed in a carrier"};
        }
    }
    std::vector<Part> parts;
    for (std::size_t start = 0;;) {
        const std::size_t plus = text.find('+', start);
        const std::size_t end = plus == std::string_view::npos ? text.size() : plus;
        if (end == start) {
            return Error{"empty part" + at(start)};
        }
        parts.push_back({text.substr(start, end - start), start});
        if (plus == std::string_view::npos) {
            break;
        }
        start = plus + 1;
    }

    Carrier carrier;
    const Part& base = parts.front();
    if (base.text.starts_with("send.") || base.text.starts_with("recv.")) {
        return Error{"carrier must start with a base carrier, e.g. 'tcp+" + std::string(base.text) +
                     "', not with the clause " + in_quotes(base.text)};
    }
    if (auto error = name_error("base carrier", base.text, base.position)) {
        return Error{*error};
    }
    carrier.base = std::string(base.text);

    for (std::size_t i = 1; i < parts.size(); ++i) {
        const Part& part = parts[i];
        // Split at the first dot only, so that values may hold dots ("tc.0.5", "file.a.b").
        const std::size_t dot = part.text.find('.');
        const std::string_view key = part.text.substr(0, dot);
        const std::optional<std::string_view> value =
            dot == std::string_view::npos ? std::nullopt : std::optional(part.text.substr(dot + 1));
        if (key.empty()) {
            return Error{"empty key in " + in_quotes(part.text) + at(part.position)};
        }
        if (key == "send" || key == "recv") {
            if (!value) {
                return Error{in_quotes(key) + at(part.position) + " needs a modifier name: '" +
                             std::string(key) + ".NAME'"};
            }
            if (value->empty()) {
                return Error{"empty modifier name in " + in_quotes(part.text) + at(part.position)};
            }
            if (auto error = name_error("modifier name", *value, part.position + dot + 1)) {
                return Error{*error};
            }
            carrier.clauses.push_back({key == "send" ? Side::send : Side::recv, std::string(*value), {}});
            continue;
        }
        if (auto error = name_error("key", key, part.position)) {
            return Error{*error};
        }
        if (key == "qos") {
            // The connection's, not a clause's: allowed before, between and after clauses.
            if (auto read = parse_qos_part(value.value_or(""), carrier.qos); !read) {
                return Error{read.error().message + at(part.position)};
            }
            continue;
        }
        if (carrier.clauses.empty()) {
            return Error{in_quotes(part.text) + at(part.position) + " comes before any send./recv. clause"};
        }
        if (value && value->empty()) {
            return Error{"missing value after " + in_quotes(part.text) + at(part.position) + " (write '" +
                         std::string(key) + "' alone for a flag)"};
        }
        Clause& clause = carrier.clauses.back();
        if (clause.find(key) != nullptr) {
            return Error{"duplicate key " + in_quotes(key) + at(part.position) + " in clause '" +
                         std::string(side_name(clause.side)) + "." + clause.modifier + "'"};
        }
        clause.params.push_back(
            {std::string(key), value ? std::optional<std::string>(*value) : std::nullopt});
    }
    return carrier;
}

Status validate_carrier(const Carrier& carrier, const CarrierSupport& support) {
    if (!contains(support.bases, carrier.base)) {
        if (contains(support.unimplemented_bases, carrier.base)) {
            return Error{"carrier " + in_quotes(carrier.base) + " is not supported by this build"};
        }
        return Error{"unknown carrier " + in_quotes(carrier.base)};
    }
    for (const auto& clause : carrier.clauses) {
        if (contains(support.modifiers, clause.modifier)) {
            continue;
        }
        const std::string name = std::string(side_name(clause.side)) + "." + clause.modifier;
        if (contains(support.unimplemented_modifiers, clause.modifier)) {
            return Error{"modifier " + in_quotes(name) + " is not supported by this build"};
        }
        return Error{"unknown modifier " + in_quotes(name)};
    }
    return Ok{};
}

}  // namespace plexus::proto
