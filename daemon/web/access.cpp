#include "access.hpp"

#include <boost/system/error_code.hpp>

#include "plexus/proto/hex.hpp"

namespace plexus::daemon::web {

namespace {

std::string_view trim(std::string_view text) {
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t'))
        text.remove_prefix(1);
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t'))
        text.remove_suffix(1);
    return text;
}

/// The host part of a Host header: "127.0.0.1:8080" -> "127.0.0.1", "[::1]:80" -> "::1".
std::string_view host_part(std::string_view host) {
    if (host.starts_with('[')) {
        const auto end = host.find(']');
        return end == std::string_view::npos ? host : host.substr(1, end - 1);
    }
    const auto colon = host.find(':');
    return colon == std::string_view::npos ? host : host.substr(0, colon);
}

bool names_an_address(std::string_view host) {
    const auto name = host_part(host);
    if (name == "localhost")
        return true;
    boost::system::error_code ec;
    boost::asio::ip::make_address(std::string(name), ec);
    return !ec;
}

}  // namespace

std::optional<std::string> token_of(std::string_view authorization, std::string_view cookies) {
    authorization = trim(authorization);
    constexpr std::string_view bearer = "Bearer ";
    if (authorization.starts_with(bearer))
        return std::string(trim(authorization.substr(bearer.size())));
    while (!cookies.empty()) {
        const auto end = cookies.find(';');
        const auto pair = trim(cookies.substr(0, end));
        constexpr std::string_view name = "plexus_token=";
        if (pair.starts_with(name))
            return std::string(pair.substr(name.size()));
        if (end == std::string_view::npos)
            break;
        cookies.remove_prefix(end + 1);
    }
    return std::nullopt;
}

namespace {

std::string percent_decoded(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] == '%' && i + 2 < text.size() && proto::hex_digit_value(text[i + 1]) >= 0 &&
            proto::hex_digit_value(text[i + 2]) >= 0) {
            out.push_back(static_cast<char>(proto::hex_digit_value(text[i + 1]) * 16 +
                                            proto::hex_digit_value(text[i + 2])));
            i += 2;
        } else {
            out.push_back(text[i]);  // a stray '%' stays as it is
        }
    }
    return out;
}
}  // namespace

std::string query_value(std::string_view query, std::string_view name) {
    while (!query.empty()) {
        const auto end = query.find('&');
        const auto pair = query.substr(0, end);
        const auto equals = pair.find('=');
        if (pair.substr(0, equals) == name)
            return equals == std::string_view::npos ? std::string()
                                                    : percent_decoded(pair.substr(equals + 1));
        if (end == std::string_view::npos)
            break;
        query.remove_prefix(end + 1);
    }
    return {};
}

Access::Access(const std::optional<proto::Secret>& secret, bool insecure) : insecure_(insecure) {
    if (secret)
        token_ = secret->web_token();
}

bool Access::token_ok(std::string_view token) const {
    return token_ && proto::same_text(*token_, token);
}

Refusal Access::check(const boost::asio::ip::address& remote, std::string_view host,
                      std::string_view authorization, std::string_view cookies) const {
    const auto token = token_of(authorization, cookies);
    if (token && token_ok(*token))
        return Refusal::none;
    if (!token_ && insecure_)
        return Refusal::none;  // open to everyone who can reach it, as --insecure says
    auto address = remote;
    if (address.is_v6() && address.to_v6().is_v4_mapped())
        address = boost::asio::ip::make_address_v4(boost::asio::ip::v4_mapped, address.to_v6());
    if (address.is_loopback())
        return names_an_address(host) ? Refusal::none : Refusal::host;
    return Refusal::token;
}

}  // namespace plexus::daemon::web
