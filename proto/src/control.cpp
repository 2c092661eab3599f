#include "plexus/proto/control.hpp"

#include <exception>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {

using nlohmann::json;

// A first pass over the CBOR that builds nothing and stops at the first container nested deeper
// than the limit. nlohmann's CBOR reader recurses once per level, so the depth must be known to be
// small before from_cbor builds the value.
class DepthCheck {
  public:
    explicit DepthCheck(std::size_t max_depth) : max_depth_(max_depth) {}

    static bool null() { return true; }
    static bool boolean(bool /*value*/) { return true; }
    static bool number_integer(json::number_integer_t /*value*/) { return true; }
    static bool number_unsigned(json::number_unsigned_t /*value*/) { return true; }
    static bool number_float(json::number_float_t /*value*/, const json::string_t& /*text*/) { return true; }
    static bool string(json::string_t& /*value*/) { return true; }
    static bool binary(json::binary_t& /*value*/) { return true; }
    static bool key(json::string_t& /*value*/) { return true; }
    bool start_object(std::size_t /*size*/) { return enter(); }
    bool end_object() { return leave(); }
    bool start_array(std::size_t /*size*/) { return enter(); }
    bool end_array() { return leave(); }
    bool parse_error(std::size_t /*position*/, const std::string& /*token*/, const json::exception& error) {
        error_ = error.what();
        return false;
    }

    const std::string& error() const { return error_; }

  private:
    bool enter() {
        if (++depth_ > max_depth_) {
            error_ = "nested deeper than " + std::to_string(max_depth_) + " levels";
            return false;
        }
        return true;
    }
    bool leave() {
        --depth_;
        return true;
    }

    std::size_t max_depth_;
    std::size_t depth_ = 0;
    std::string error_;
};

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
    auto body = decode_cbor(bytes);
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

Result<json> decode_cbor(ByteView bytes, std::size_t max_depth) {
    // nlohmann may still throw from inside (an excessive declared array size, allocation failure);
    // nothing may escape a decoder, so every path ends in a value or an Error.
    try {
        DepthCheck check(max_depth);
        if (!json::sax_parse(bytes.begin(), bytes.end(), &check, json::input_format_t::cbor, true)) {
            return Error{"bad CBOR: " + (check.error().empty() ? std::string("malformed") : check.error())};
        }
        json value = json::from_cbor(bytes.begin(), bytes.end(), /*strict=*/true, /*allow_exceptions=*/false);
        if (value.is_discarded()) {
            return Error{"bad CBOR: malformed"};
        }
        return value;
    } catch (const std::exception& error) {
        return Error{std::string("bad CBOR: ") + error.what()};
    } catch (...) {
        return Error{"bad CBOR: malformed"};
    }
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
