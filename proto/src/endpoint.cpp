#include "plexus/proto/endpoint.hpp"

namespace plexus::proto {

namespace {

std::string quoted(std::string_view text) {
    return "'" + std::string(text) + "'";
}

Result<std::uint16_t> parse_port(std::string_view port, std::string_view text) {
    if (port.empty()) {
        return Error{"missing port in " + quoted(text) + "; expected HOST:PORT, e.g. 127.0.0.1:10100"};
    }
    std::uint32_t value = 0;
    for (const char c : port) {
        if (c < '0' || c > '9') {
            return Error{"port " + quoted(port) + " in " + quoted(text) + " is not a number"};
        }
        value = value * 10 + static_cast<std::uint32_t>(c - '0');
        // Checked on every digit, so that a long run of digits cannot overflow the accumulator.
        if (value > 65535) {
            return Error{"port " + quoted(port) + " in " + quoted(text) + " is out of range (0-65535)"};
        }
    }
    return static_cast<std::uint16_t>(value);
}

}  // namespace

Result<Endpoint> parse_endpoint(std::string_view text) {
    if (text.empty()) {
        return Error{"empty address; expected HOST:PORT, e.g. 127.0.0.1:10100"};
    }
    for (const char c : text) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte <= 0x20 || byte >= 0x7f) {
            return Error{"address " + quoted(text) + " contains a space or control character"};
        }
    }
    std::string_view host;
    std::string_view rest;
    if (text.front() == '[') {
        // "[IPv6]:PORT": the brackets keep the address's own colons apart from the port's.
        const std::size_t close = text.find(']');
        if (close == std::string_view::npos) {
            return Error{"address " + quoted(text) + " has '[' without ']'"};
        }
        host = text.substr(1, close - 1);
        rest = text.substr(close + 1);
        if (rest.empty()) {
            return Error{"missing port in " + quoted(text) + "; expected [HOST]:PORT, e.g. [::1]:5000"};
        }
        if (rest.front() != ':') {
            return Error{"address " + quoted(text) + " must have ':' right after ']'"};
        }
        rest.remove_prefix(1);
    } else {
        const std::size_t colon = text.rfind(':');
        if (colon == std::string_view::npos) {
            return Error{"missing port in " + quoted(text) + "; expected HOST:PORT, e.g. 127.0.0.1:10100"};
        }
        host = text.substr(0, colon);
        rest = text.substr(colon + 1);
        if (host.find(':') != std::string_view::npos) {
            return Error{"address " + quoted(text) +
                         " is ambiguous: write an IPv6 address in brackets, e.g. [::1]:5000"};
        }
    }
    if (host.empty()) {
        return Error{"missing host in " + quoted(text) + "; expected HOST:PORT, e.g. 127.0.0.1:10100"};
    }
    if (host.find_first_of("[]") != std::string_view::npos) {
        return Error{"address " + quoted(text) + " has a stray bracket"};
    }
    auto port = parse_port(rest, text);
    if (!port) {
        return port.error();
    }
    return Endpoint{std::string(host), *port};
}

}  // namespace plexus::proto
