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

proto::Result<std::optional<proto::Secret>> load_deployment_secret(const std::string& flag_path,
                                                                   const std::string& identity_flag,
                                                                   proto::Subject::Kind kind) {
    const auto flag_or_env = [](const std::string& flag, const char* variable) {
        if (!flag.empty())
            return flag;
        const char* env = std::getenv(variable);
        return std::string(env && *env ? env : "");
    };
    const std::string path = flag_or_env(flag_path, "PLEXUS_SECRET_FILE");
    const std::string identity_dir = flag_or_env(identity_flag, "PLEXUS_IDENTITY");
    if (path.empty()) {
        if (!identity_dir.empty())
            return proto::Error{
                "--identity needs the deployment secret too (--secret-file or PLEXUS_SECRET_FILE): "
                "identities come on top of it"};
        return std::optional<proto::Secret>{};
    }
    auto secret = proto::Secret::load(path);
    if (!secret)
        return secret.error();
    if (!identity_dir.empty()) {
        auto identity = proto::Identity::load(identity_dir);
        if (!identity)
            return identity.error();
        if (identity->subject().kind != kind) {
            const proto::Subject wanted{kind, "NAME"};
            return proto::Error{"identity " + identity_dir + " is that of " + identity->subject().text() +
                                "; this program needs one of a " +
                                (kind == proto::Subject::Kind::names ? "name server" : "node") + " (" +
                                wanted.uri() + ": `plexus pki issue" +
                                (kind == proto::Subject::Kind::names ? " --names" : "") + "`)"};
        }
        secret->set_identity(*identity);
    }
    return std::optional<proto::Secret>{*secret};
}

void reload_permissions(PermissionGate& gate, std::string_view log_prefix) {
    if (auto reloaded = gate.reload(); !reloaded)
        spdlog::error("{}SIGHUP: permissions not reloaded: {}", log_prefix, reloaded.error().message);
    else
        spdlog::info("{}SIGHUP: permissions reloaded from {}", log_prefix, gate.summary());
}

proto::Result<std::shared_ptr<const Permissions>> load_permissions(const std::string& path) {
    if (path.empty())
        return std::shared_ptr<const Permissions>{};
    auto permissions = Permissions::load(path);
    if (!permissions)
        return permissions.error();
    return std::shared_ptr<const Permissions>(std::make_shared<const Permissions>(std::move(*permissions)));
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
