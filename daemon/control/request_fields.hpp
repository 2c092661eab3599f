#pragma once
// Reading the arguments of a control request's CBOR map, and making its reply.

#include <string>

#include <nlohmann/json.hpp>

#include "plexus/proto/control.hpp"

namespace plexus::daemon {

/// The text field `key` of a request body, or "" when it is missing or not text.
inline std::string text(const nlohmann::json& body, const char* key) {
    auto it = body.find(key);
    if (it == body.end() || !it->is_string())
        return {};
    return it->get<std::string>();
}

inline proto::Reply ok(nlohmann::json body = nlohmann::json::object()) {
    return {0, proto::ReplyCode::ok, std::move(body)};
}
inline proto::Reply refuse(std::string why, proto::ReplyCode code = proto::ReplyCode::refused) {
    return proto::make_refusal(0, code, std::move(why));
}
inline proto::Reply relay(const proto::Result<proto::Reply>& reply) {
    if (!reply)
        return refuse(reply.error().message);
    return *reply;
}

}  // namespace plexus::daemon
