#include "plexus/proto/port_name.hpp"

#include "plexus/proto/message.hpp"

namespace plexus::proto {

namespace {

bool is_allowed(char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == '/' || c == ':' || c == '-';
}

// A character as a user can read it in a message, even when it is not printable.
std::string show_char(char c) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte >= 0x7f) {
        constexpr std::string_view digits = "0123456789abcdef";
        return {'\\', 'x', digits[byte >> 4], digits[byte & 0x0f]};
    }
    // Braces would pick the initializer-list constructor and give "\x01" followed by c.
    return std::string(1, c);  // NOLINT(modernize-return-braced-init-list)
}

// The name as quoted in messages: printable, and short enough to read when the name is huge.
std::string quote(std::string_view name) {
    constexpr std::size_t shown = 64;
    std::string text = "\"";
    for (std::size_t i = 0; i < name.size() && i < shown; ++i) {
        text += show_char(name[i]);
    }
    if (name.size() > shown) {
        text += "...";
    }
    return text + "\"";
}

}  // namespace

std::optional<std::string> port_name_error(std::string_view name) {
    if (name.empty()) {
        return "port name is empty; it must start with '/', e.g. \"/camera/out\"";
    }
    const std::string quoted = "port name " + quote(name);
    if (name.size() > max_port_name) {
        return quoted + " is " + std::to_string(name.size()) + " bytes, longer than the limit of " +
               std::to_string(max_port_name);
    }
    if (name.front() != '/') {
        return quoted + " must start with '/'";
    }
    for (std::size_t i = 0; i < name.size(); ++i) {
        if (name[i] == ' ' || name[i] == '\t' || name[i] == '\n' || name[i] == '\r') {
            return quoted + " must not contain spaces (found '" + show_char(name[i]) + "' at position " +
                   std::to_string(i) + ")";
        }
    }
    for (std::size_t i = 0; i < name.size(); ++i) {
        if (!is_allowed(name[i])) {
            return quoted + " has character '" + show_char(name[i]) + "' at position " + std::to_string(i) +
                   "; allowed are A-Z a-z 0-9 _ . / : -";
        }
    }
    if (const auto at = name.find("//"); at != std::string_view::npos) {
        return quoted + " must not contain \"//\" (at position " + std::to_string(at) + ")";
    }
    if (name.back() == '/') {
        return quoted + " must not end with '/'";
    }
    return std::nullopt;
}

}  // namespace plexus::proto
