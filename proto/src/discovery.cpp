#include "plexus/proto/discovery.hpp"

#include "plexus/proto/name_operations.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "plexus/proto/control.hpp"
#include "plexus/proto/datagram_seal.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::proto {

namespace {

std::optional<std::string> environment(const char* name) {
    const char* value = std::getenv(name);
    if (!value || !*value)
        return std::nullopt;
    return std::string(value);
}

bool unspecified(const std::string& host) {
    return host.empty() || host == "0.0.0.0" || host == "::";
}

}  // namespace

std::string NamesChoice::how() const {
    switch (source) {
        case NamesSource::flag:
            return "from --names";
        case NamesSource::environment:
            return "from PLEXUS_NAMES";
        case NamesSource::config:
            return "from the config file " + detail;
        case NamesSource::discovery:
            return "found by multicast discovery on " + detail;
        case NamesSource::fallback:
            return "the default; " + detail;
    }
    return detail;
}

Result<std::optional<Endpoint>> discovery_group() {
    const std::string text = environment("PLEXUS_DISCOVERY").value_or(default_discovery_group);
    if (text == "off")
        return std::optional<Endpoint>{};
    auto parsed = parse_endpoint(text);
    if (!parsed)
        return Error{"PLEXUS_DISCOVERY: " + parsed.error().message + " (expected GROUP:PORT or off)"};
    return std::optional<Endpoint>{*parsed};
}

std::string default_config_file() {
    std::vector<std::string> candidates;
    if (auto path = environment("PLEXUS_CONFIG"))
        return *path;  // named explicitly: used (and reported) even if it is missing
    if (auto xdg = environment("XDG_CONFIG_HOME"))
        candidates.push_back(*xdg + "/plexus/config.json");
    else if (auto home = environment("HOME"))
        candidates.push_back(*home + "/.config/plexus/config.json");
    candidates.emplace_back("/etc/plexus/config.json");
    for (const auto& candidate : candidates) {
        std::error_code ignored;
        if (std::filesystem::exists(candidate, ignored))
            return candidate;
    }
    return {};
}

Result<std::optional<std::string>> names_in_config(const std::string& path) {
    std::ifstream in(path);
    if (!in)
        return std::optional<std::string>{};
    auto json = nlohmann::json::parse(in, nullptr, false, true);
    if (json.is_discarded() || !json.is_object())
        return Error{"config file " + path + " is not a JSON object"};
    const auto it = json.find("names");
    if (it == json.end())
        return std::optional<std::string>{};
    if (!it->is_string())
        return Error{"config file " + path + ": \"names\" must be a text HOST:PORT"};
    return std::optional<std::string>{it->get<std::string>()};
}

Result<NamesChoice> choose_names(const std::optional<std::string>& flag, const std::string& config_file,
                                 const std::function<std::optional<std::string>()>& discover) {
    if (flag)
        return NamesChoice{*flag, NamesSource::flag, {}};
    if (auto env = environment("PLEXUS_NAMES"))
        return NamesChoice{*env, NamesSource::environment, {}};
    const std::string path = config_file.empty() ? default_config_file() : config_file;
    if (!path.empty()) {
        auto configured = names_in_config(path);
        if (!configured)
            return configured.error();
        if (*configured)
            return NamesChoice{**configured, NamesSource::config, path};
    }
    auto group = discovery_group();
    if (!group)
        return group.error();
    if (*group) {
        if (auto found = discover())
            return NamesChoice{*found, NamesSource::discovery, (*group)->text()};
        return NamesChoice{default_names_address, NamesSource::fallback,
                           "no name server answered on " + (*group)->text()};
    }
    return NamesChoice{default_names_address, NamesSource::fallback, "discovery is off (PLEXUS_DISCOVERY)"};
}

std::string discovery_nonce() {
    // A datagram key is 16 random bytes as hex: just what a nonce needs.
    return key_text(random_datagram_key());
}

Bytes discovery_query(const std::string& nonce) {
    return encode_request({1, DiscoverRequest{nonce}.encode()});
}

std::optional<DiscoveryAnswer> discovery_answer(ByteView datagram, const std::string& from,
                                                const Secret* secret, const std::string& nonce) {
    FrameDecoder decoder(datagram.size() + 16);
    const auto decoded = decoder.decode(datagram);
    if (decoded.status != DecodeStatus::frame || decoded.type != FrameType::reply)
        return std::nullopt;
    auto reply = decode_reply(decoded.fields);
    if (!reply || reply->code != ReplyCode::ok)
        return std::nullopt;
    const auto answer = DiscoverReply::decode(reply->body);
    if (!answer)
        return std::nullopt;
    auto endpoint = parse_endpoint(answer->names);
    if (!endpoint || endpoint->port == 0)
        return std::nullopt;
    DiscoveryAnswer out;
    // The proof covers the address as the name server wrote it, before HOST is filled in.
    out.proven = secret != nullptr && !nonce.empty() &&
                 same_text(answer->proof, secret->discovery_proof(nonce, answer->names));
    if (unspecified(endpoint->host))
        endpoint->host = from;
    out.names = endpoint->text();
    return out;
}

Bytes discovery_reply(std::uint64_t id, const Endpoint& names, const Secret* secret,
                      const std::string& nonce) {
    Endpoint advertised = names;
    if (unspecified(advertised.host))
        advertised.host = "0.0.0.0";
    DiscoverReply reply{advertised.text()};
    if (secret && !nonce.empty())
        reply.proof = secret->discovery_proof(nonce, reply.names);
    return encode_reply({id, ReplyCode::ok, reply.encode()});
}

}  // namespace plexus::proto
