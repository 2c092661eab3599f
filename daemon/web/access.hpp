#pragma once
// Threading: values and pure functions.
//
// Who the web endpoint answers (docs/SECURITY.md, "The web endpoint"): loopback always; beyond
// loopback, with a deployment secret, only a request carrying the web token; with --insecure and
// no secret, everyone. The token is compared in constant time.

#include <optional>
#include <string>
#include <string_view>

#include <boost/asio/ip/address.hpp>

#include "plexus/proto/auth.hpp"

namespace plexus::daemon::web {

/// The token a request carries: `Authorization: Bearer TOKEN`, else the cookie `plexus_token`.
std::optional<std::string> token_of(std::string_view authorization, std::string_view cookies);

/// The value of `name` in a query string (`port=%2Fgaze%2Fin&check=true`), %XX decoded (as a
/// browser's encodeURIComponent writes it; '+' is left as it is, being legal in names); "" when
/// absent.
std::string query_value(std::string_view query, std::string_view name);

/// Why a request is refused, or nothing when it may be answered.
enum class Refusal { none, token, host };

class Access {
public:
    /// `secret`: the deployment's, if any; `insecure`: --insecure.
    Access(const std::optional<proto::Secret>& secret, bool insecure);

    /// Whether a request from `remote` with these `Host`, `Authorization` and `Cookie` headers may
    /// be answered. A request without a token must name a loopback host or an IP address in
    /// `Host`: a page elsewhere that rebinds its own name to 127.0.0.1 (DNS rebinding) cannot
    /// then read the views through a visitor's browser.
    Refusal check(const boost::asio::ip::address& remote, std::string_view host,
                  std::string_view authorization, std::string_view cookies) const;
    /// True when `token` is the web token (constant time); false without a secret.
    bool token_ok(std::string_view token) const;

private:
    std::optional<std::string> token_;  ///< derived from the secret once
    bool insecure_;
};

}  // namespace plexus::daemon::web
