#include "reachable_address.hpp"

#include "plexus/proto/endpoint.hpp"

namespace plexus::daemon::names {

namespace {
std::optional<asio::ip::address> ip_of(const std::string& host) {
    boost::system::error_code ec;
    auto address = asio::ip::make_address(host, ec);
    if (ec)
        return std::nullopt;
    return address;
}

std::string with_host(const asio::ip::address& host, std::uint16_t port) {
    return proto::Endpoint{host.to_string(), port}.text();
}
}  // namespace

std::string recorded_address(const std::string& announced, const SessionAddresses& daemon) {
    const auto endpoint = proto::parse_endpoint(announced);
    if (!endpoint || !daemon.remote)
        return announced;
    const auto host = ip_of(endpoint->host);
    if (!host || !host->is_unspecified())
        return announced;
    return with_host(*daemon.remote, endpoint->port);
}

std::string address_for(const std::string& recorded, const SessionAddresses& asker) {
    if (!asker.remote || !asker.local || asker.remote->is_loopback() || asker.local->is_loopback())
        return recorded;
    const auto endpoint = proto::parse_endpoint(recorded);
    if (!endpoint)
        return recorded;
    const auto host = ip_of(endpoint->host);
    if (!host || !host->is_loopback())
        return recorded;
    return with_host(*asker.local, endpoint->port);
}

}  // namespace plexus::daemon::names
