#include "broker_address.hpp"

#include <charconv>

#include "mapping.hpp"

namespace plexus::bridge {

BrokerAddress parse_broker(const std::string& text) {
    const auto fail = [&text](const std::string& why) {
        return UsageError("--broker '" + text + "': " + why + " (expected HOST:PORT, e.g. localhost:1883)");
    };
    const auto colon = text.rfind(':');
    if (colon == std::string::npos)
        throw fail("the port is missing");
    BrokerAddress address;
    address.host = text.substr(0, colon);
    if (address.host.size() >= 2 && address.host.front() == '[' && address.host.back() == ']')
        address.host = address.host.substr(1, address.host.size() - 2);
    if (address.host.empty())
        throw fail("the host is empty");
    const auto port_text = text.substr(colon + 1);
    int port = 0;
    const auto [end, error] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
    if (port_text.empty() || error != std::errc() || end != port_text.data() + port_text.size() || port < 1 ||
        port > 65535)
        throw fail("the port is not a number from 1 to 65535");
    address.port = port;
    return address;
}

}  // namespace plexus::bridge
