#include "trust.hpp"

#include <cstdlib>

#include <spdlog/spdlog.h>
#include <boost/asio/ip/address.hpp>

namespace plexus::daemon {

namespace {
bool loopback(const std::string& host) {
    if (host == "localhost")
        return true;
    boost::system::error_code ec;
    const auto address = boost::asio::ip::make_address(host, ec);
    return !ec && address.is_loopback();
}
}  // namespace

proto::Result<std::optional<proto::Secret>> load_deployment_secret(const std::string& flag_path) {
    std::string path = flag_path;
    if (path.empty()) {
        if (const char* env = std::getenv("PLEXUS_SECRET_FILE"); env && *env)
            path = env;
    }
    if (path.empty())
        return std::optional<proto::Secret>{};
    auto secret = proto::Secret::load(path);
    if (!secret)
        return secret.error();
    return std::optional<proto::Secret>{*secret};
}

proto::Status check_listening(const std::vector<std::string>& hosts, bool has_secret, bool insecure,
                              const std::string& program) {
    if (has_secret)
        return proto::Ok{};
    for (const auto& host : hosts) {
        if (loopback(host))
            continue;
        if (!insecure) {
            return proto::Error{program + " will not listen on " + host +
                                " without a deployment secret: anyone on that network could register, "
                                "connect and write. Give it --secret-file FILE (or PLEXUS_SECRET_FILE), or "
                                "--insecure on a network you trust completely"};
        }
        spdlog::warn("**********************************************************************");
        spdlog::warn("INSECURE: {} listens on {} with no deployment secret (--insecure).", program, host);
        spdlog::warn("Anyone who can reach it can register ports, connect, write and forge data.");
        spdlog::warn("**********************************************************************");
    }
    return proto::Ok{};
}

}  // namespace plexus::daemon
