#include "plexus/proto/control.hpp"

#include <algorithm>

#include "plexus/proto/cbor.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {

using nlohmann::json;

// The body of a request or reply: a CBOR map. A null body is what a default-constructed json
// holds, so it is sent as an empty map rather than as a body the peer would refuse.
void append_body(Bytes& out, const json& body) {
    if (body.is_null()) {
        json::to_cbor(json::object(), out);
    } else {
        json::to_cbor(body, out);
    }
}

Result<json> decode_map(ByteView bytes, std::string_view what) {
    if (bytes.empty()) {
        return Error{"bad " + std::string(what) + ": missing CBOR body"};
    }
    auto body = decode_cbor(bytes, max_body_depth);
    if (!body) {
        return Error{"bad " + std::string(what) + ": " + body.error().message};
    }
    if (!body->is_object()) {
        return Error{"bad " + std::string(what) + ": body is a CBOR " + std::string(body->type_name()) +
                     ", not a map"};
    }
    return body;
}

}  // namespace

namespace {
// Recursion bounded by `stop_after`: it never goes more than stop_after + 1 calls deep, whatever the
// value, and allocates nothing (it runs on every message a client writes).
std::size_t depth_below(const json& node, std::size_t depth, std::size_t stop_after) {
    if (!node.is_array() && !node.is_object())
        return depth;
    const std::size_t inside = depth + 1;
    if (inside > stop_after)
        return inside;
    std::size_t deepest = inside;
    for (const auto& child : node) {
        deepest = std::max(deepest, depth_below(child, inside, stop_after));
        if (deepest > stop_after)
            break;
    }
    return deepest;
}
}  // namespace

std::size_t nesting_depth(const json& value, std::size_t stop_after) {
    return depth_below(value, 0, stop_after);
}

Status check_value_depth(const json& value, const std::string& what) {
    if (nesting_depth(value) <= max_cbor_depth)
        return Ok{};
    return Error{what + " nests arrays and maps deeper than " + std::to_string(max_cbor_depth) +
                 " levels: no reader could decode it (flatten it, or send it as a string or blob)"};
}

Result<json> decode_cbor(ByteView bytes, std::size_t max_depth) {
    auto value = decode_cbor_fast(bytes, max_depth);
    if (!value) {
        return Error{"bad CBOR: " + value.error().message};
    }
    return value;
}

Bytes encode_request(const Request& request) {
    Bytes fields;
    append_varint(fields, request.id);
    append_body(fields, request.body);
    Bytes out;
    append_frame(out, FrameType::request, fields);
    return out;
}

Bytes encode_reply(const Reply& reply) {
    Bytes fields;
    append_varint(fields, reply.id);
    append_varint(fields, static_cast<std::uint32_t>(reply.code));
    append_body(fields, reply.body);
    Bytes out;
    append_frame(out, FrameType::reply, fields);
    return out;
}

Result<Request> decode_request(ByteView fields) {
    FieldReader reader(fields);
    const auto id = reader.varint("request id");
    if (!id) {
        return Error{"bad request: " + reader.error()};
    }
    auto body = decode_map(reader.rest(), "request");
    if (!body) {
        return body.error();
    }
    const auto op = body->find("op");
    if (op == body->end()) {
        return Error{"bad request: no \"op\""};
    }
    if (!op->is_string()) {
        return Error{"bad request: \"op\" is a " + std::string(op->type_name()) + ", not a string"};
    }
    return Request{*id, std::move(*body)};
}

Result<Reply> decode_reply(ByteView fields) {
    FieldReader reader(fields);
    const auto id = reader.varint("reply id");
    const auto code = reader.varint("reply code");
    if (reader.failed()) {
        return Error{"bad reply: " + reader.error()};
    }
    if (*code > static_cast<std::uint32_t>(ReplyCode::refused)) {
        return Error{"bad reply: unknown reply code " + std::to_string(*code)};
    }
    auto body = decode_map(reader.rest(), "reply");
    if (!body) {
        return body.error();
    }
    return Reply{*id, static_cast<ReplyCode>(*code), std::move(*body)};
}

Reply make_refusal(std::uint64_t id, ReplyCode code, std::string reason) {
    return Reply{id, code, json{{"error", std::move(reason)}}};
}

}  // namespace plexus::proto
