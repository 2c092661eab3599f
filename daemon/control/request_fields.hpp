#pragma once
// Making the replies of control requests. The requests themselves are read through the structs of
// plexus/proto/operations.hpp and name_operations.hpp.

#include <string>

#include <nlohmann/json.hpp>

#include "plexus/proto/control.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::daemon {

inline proto::Reply ok(nlohmann::json body = nlohmann::json::object()) {
    return {0, proto::ReplyCode::ok, std::move(body)};
}
/// A reply struct of operations.hpp, encoded.
template <class Answer>
requires requires(const Answer& answer) {
    answer.encode();
}
proto::Reply ok(const Answer& answer) {
    return ok(answer.encode());
}
inline proto::Reply refuse(std::string why, proto::ReplyCode code = proto::ReplyCode::refused) {
    return proto::make_refusal(0, code, std::move(why));
}
/// The answer to a request whose fields did not decode (a field of the wrong type): code 2.
inline proto::Reply malformed(const proto::Error& why) {
    return refuse(why.message, proto::ReplyCode::usage);
}
inline proto::Reply relay(const proto::Result<proto::Reply>& reply) {
    if (!reply)
        return refuse(reply.error().message);
    return *reply;
}

}  // namespace plexus::daemon
