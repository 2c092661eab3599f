// `plexus web`: where the local daemon serves its web page (docs/WEB.md), and the token a browser
// beyond loopback needs. Opens nothing by itself: on a robot there is often no browser to open.
#include <cstdlib>
#include <iostream>

#include "commands.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/operations.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

/// A wildcard listening address is reached locally through loopback.
std::string local_url(std::string address, bool tls) {
    if (address.starts_with("0.0.0.0:"))
        address = "127.0.0.1:" + address.substr(8);
    else if (address.starts_with("[::]:"))
        address = "[::1]:" + address.substr(5);
    return (tls ? "https://" : "http://") + address + "/";
}

}  // namespace

int web(const Common& common, bool token) {
    if (token) {
        const char* path = std::getenv("PLEXUS_SECRET_FILE");
        if (!path || !*path)
            throw Error(ErrorCode::usage,
                        "there is a web token only with a deployment secret: give --secret-file or set "
                        "PLEXUS_SECRET_FILE");
        auto secret = proto::Secret::load(path);
        if (!secret)
            throw Error(ErrorCode::usage, secret.error().message);
        std::cout << secret->web_token() << '\n';
        return 0;
    }
    auto client = plexus::Client({common.socket});
    const auto node = read_as<proto::NodeReply>(client.request(proto::NodeRequest{}.encode()));
    const std::string address = node.http;
    if (address.empty()) {
        std::cerr << "plexus: the daemon at " << common.socket
                  << " serves no web page; start it with --http 127.0.0.1:8080 (or the config key "
                     "\"http\")\n";
        return 1;
    }
    std::cout << local_url(address, node.http_tls) << '\n';
    if (!node.http_fingerprint.empty())
        std::cout << "certificate: self-signed by the daemon at its start, SHA-256 " << node.http_fingerprint
                  << "\n  (your browser warns about it: accept it only if it shows this fingerprint)\n";
    return 0;
}

}  // namespace plexus::cli
