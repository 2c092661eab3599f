// The decoders of every frame's fields but data and data_batch (message_fuzz.cpp has those):
// hello, auth, request, reply, error, the shared-memory frames, call and answer, the rings request
// and answer; and the two datagrams that are not frames on a stream: the udp carrier's datagram
// (starts with "PLXD") and the discovery answer.
// The input is a whole frame, as a session reads it. Property, for each decoder: what it decodes,
// encoded again by the matching encoder, decodes to the same value.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/datagram.hpp"
#include "plexus/proto/discovery.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/rings.hpp"
#include "plexus/proto/shm.hpp"
#include "same_json.hpp"

namespace proto = plexus::proto;
using plexus::fuzz::same_json;

namespace {

proto::Bytes copy(proto::ByteView bytes) {
    return {bytes.begin(), bytes.end()};
}

/// The fields of the one frame that `frame` holds, with the type it must have.
proto::ByteView fields_of(const proto::Bytes& frame, proto::FrameType type) {
    const auto decoded = proto::FrameDecoder().decode(frame);
    PLEXUS_FUZZ_CHECK(decoded.status == proto::DecodeStatus::frame && decoded.used == frame.size() &&
                      decoded.type == type);
    return decoded.fields;
}

void check_hello(proto::ByteView fields) {
    const auto hello = proto::decode_hello(fields);
    if (!hello)
        return;
    const auto frame = proto::encode_hello(*hello);
    const auto again = proto::decode_hello(fields_of(frame, proto::FrameType::hello));
    PLEXUS_FUZZ_CHECK(again.ok() && again->version == hello->version && again->role == hello->role &&
                      again->node == hello->node && again->nonce == hello->nonce &&
                      again->has_secret == hello->has_secret);
}

void check_request(proto::ByteView fields) {
    const auto request = proto::decode_request(fields);
    if (!request)
        return;
    PLEXUS_FUZZ_CHECK(request->body.is_object() && request->body["op"].is_string());
    const auto frame = proto::encode_request(*request);
    const auto again = proto::decode_request(fields_of(frame, proto::FrameType::request));
    PLEXUS_FUZZ_CHECK(again.ok() && again->id == request->id && same_json(again->body, request->body));
}

void check_reply(proto::ByteView fields) {
    const auto reply = proto::decode_reply(fields);
    if (!reply)
        return;
    const auto frame = proto::encode_reply(*reply);
    const auto again = proto::decode_reply(fields_of(frame, proto::FrameType::reply));
    PLEXUS_FUZZ_CHECK(again.ok() && again->id == reply->id && again->code == reply->code &&
                      same_json(again->body, reply->body));
}

void check_error(proto::ByteView fields) {
    const auto reason = proto::decode_error(fields);
    if (!reason)
        return;
    // make_error_frame cuts reasons longer than max_error_reason.
    const auto frame = proto::make_error_frame(*reason);
    const auto again = proto::decode_error(fields_of(frame, proto::FrameType::error));
    PLEXUS_FUZZ_CHECK(again.ok());
    if (reason->size() <= proto::max_error_reason)
        PLEXUS_FUZZ_CHECK(*again == *reason);
    else
        PLEXUS_FUZZ_CHECK(again->size() <= proto::max_error_reason + 16);
}

void check_shm_data(proto::ByteView fields) {
    const auto data = proto::decode_shm_data(fields);
    if (!data)
        return;
    const auto head = proto::decode_record(data->head);
    PLEXUS_FUZZ_CHECK(head.ok() && head->payload.empty());
    proto::Bytes rest;
    proto::append_shm_place(rest, data->place, head->source, head->seq, head->time_ns);
    proto::Bytes frame;
    proto::append_shm_frame_prefix(frame, data->handle, rest.size());
    frame.insert(frame.end(), rest.begin(), rest.end());
    const auto again = proto::decode_shm_data(fields_of(frame, proto::FrameType::data_shm));
    PLEXUS_FUZZ_CHECK(again.ok() && again->handle == data->handle &&
                      again->place.region == data->place.region &&
                      again->place.offset == data->place.offset && again->place.length == data->place.length);
    const auto again_head = proto::decode_record(again->head);
    PLEXUS_FUZZ_CHECK(again_head.ok() && again_head->source == head->source && again_head->seq == head->seq &&
                      again_head->time_ns == head->time_ns);
}

void check_shm_region(proto::ByteView fields) {
    const auto region = proto::decode_shm_region(fields);
    if (!region)
        return;
    const auto frame = proto::make_shm_region_frame(*region);
    const auto again = proto::decode_shm_region(fields_of(frame, proto::FrameType::shm_region));
    PLEXUS_FUZZ_CHECK(again.ok() && again->region == region->region && again->size == region->size &&
                      again->writable == region->writable);
}

void check_shm_number(proto::ByteView fields, proto::FrameType type) {
    const auto number = proto::decode_shm_number(fields, "count");
    if (!number)
        return;
    const auto frame = proto::make_shm_number_frame(type, *number);
    const auto again = proto::decode_shm_number(fields_of(frame, type), "count");
    PLEXUS_FUZZ_CHECK(again.ok() && *again == *number);
}

void check_shm_free(proto::ByteView fields) {
    const auto free = proto::decode_shm_free(fields);
    if (!free)
        return;
    const auto frame = proto::make_shm_free_frame(free->first, free->second);
    const auto again = proto::decode_shm_free(fields_of(frame, proto::FrameType::shm_free));
    PLEXUS_FUZZ_CHECK(again.ok() && *again == *free);
}

void check_call(proto::ByteView fields) {
    const auto call = proto::decode_call(fields);
    if (!call)
        return;
    PLEXUS_FUZZ_CHECK(call->timeout_ms <= proto::max_call_timeout_ms);
    proto::Bytes frame;
    proto::append_call_frame(frame, call->handle, call->id, call->timeout_ms, call->record);
    const auto again = proto::decode_call(fields_of(frame, proto::FrameType::call));
    PLEXUS_FUZZ_CHECK(again.ok() && again->handle == call->handle && again->id == call->id &&
                      again->timeout_ms == call->timeout_ms && copy(again->record) == copy(call->record));
}

void check_answer(proto::ByteView fields) {
    const auto answer = proto::decode_answer(fields);
    if (!answer)
        return;
    proto::Bytes frame;
    if (answer->outcome == proto::CallOutcome::ok)
        proto::append_answer_frame(frame, answer->id, answer->record);
    else
        proto::append_failed_answer_frame(frame, answer->id, answer->outcome, answer->reason);
    const auto again = proto::decode_answer(fields_of(frame, proto::FrameType::answer));
    PLEXUS_FUZZ_CHECK(again.ok() && again->id == answer->id && again->outcome == answer->outcome &&
                      copy(again->record) == copy(answer->record) && again->reason == answer->reason);
}

void check_rings(proto::ByteView fields) {
    // One frame type, two layouts: the client's request and the daemon's answer. Each decoder in turn.
    if (const auto wanted = proto::decode_rings_request(fields)) {
        const auto frame = proto::make_rings_request(*wanted);
        const auto again = proto::decode_rings_request(fields_of(frame, proto::FrameType::rings));
        PLEXUS_FUZZ_CHECK(again.ok() && *again == *wanted);
        // Whatever a client asks for, the daemon's size is a power of two within the bounds.
        const std::size_t bytes = proto::RingLayout::ring_bytes_for(*wanted);
        PLEXUS_FUZZ_CHECK(bytes >= proto::RingLayout::min_ring_bytes &&
                          bytes <= proto::RingLayout::max_ring_bytes && (bytes & (bytes - 1)) == 0);
    }
    if (const auto answer = proto::decode_rings_answer(fields)) {
        PLEXUS_FUZZ_CHECK(answer->reason.size() <= 4096);
        const auto frame = proto::make_rings_answer(*answer);
        const auto again = proto::decode_rings_answer(fields_of(frame, proto::FrameType::rings));
        PLEXUS_FUZZ_CHECK(again.ok() && again->ring_bytes == answer->ring_bytes &&
                          again->reason == answer->reason);
    }
}

void check_datagram(proto::ByteView datagram) {
    constexpr std::uint64_t max_message = 1u << 20;
    const auto decoded = proto::decode_datagram(datagram, max_message);
    if (!decoded)
        return;
    const auto& header = decoded->header;
    PLEXUS_FUZZ_CHECK(header.length <= max_message);
    PLEXUS_FUZZ_CHECK(header.index < proto::fragment_count(header.length, header.fragment_size));
    PLEXUS_FUZZ_CHECK(decoded->tag.size() == (header.sealed ? proto::datagram_sealed_tag_size : 0));
    PLEXUS_FUZZ_CHECK(decoded->head.size() + decoded->fragment.size() + decoded->tag.size() ==
                      datagram.size());
    proto::Bytes again;
    proto::append_datagram_header(again, header);
    again.insert(again.end(), decoded->fragment.begin(), decoded->fragment.end());
    again.insert(again.end(), decoded->tag.begin(), decoded->tag.end());
    const auto reread = proto::decode_datagram(again, max_message);
    PLEXUS_FUZZ_CHECK(reread.ok());
    const auto& h = reread->header;
    PLEXUS_FUZZ_CHECK(h.stream == header.stream && h.message == header.message && h.length == header.length &&
                      h.fragment_size == header.fragment_size && h.index == header.index &&
                      h.sealed == header.sealed);
    PLEXUS_FUZZ_CHECK(copy(reread->fragment) == copy(decoded->fragment) &&
                      copy(reread->tag) == copy(decoded->tag));
}

void check_discovery_answer(proto::ByteView datagram) {
    const auto names = proto::discovery_answer(datagram, "192.0.2.1");
    if (!names)
        return;
    // What a program then connects to must be an address it can parse.
    const auto endpoint = proto::parse_endpoint(names->names);
    PLEXUS_FUZZ_CHECK(endpoint.ok() && endpoint->port != 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const proto::ByteView input(data, size);
    check_datagram(input);
    check_discovery_answer(input);
    const auto frame = proto::FrameDecoder().decode(input);
    if (frame.status != proto::DecodeStatus::frame)
        return 0;
    switch (frame.type) {
        case proto::FrameType::hello:
            check_hello(frame.fields);
            break;
        case proto::FrameType::request:
            check_request(frame.fields);
            break;
        case proto::FrameType::reply:
            check_reply(frame.fields);
            break;
        case proto::FrameType::error:
            check_error(frame.fields);
            break;
        case proto::FrameType::data_shm:
            check_shm_data(frame.fields);
            break;
        case proto::FrameType::shm_region:
            check_shm_region(frame.fields);
            break;
        case proto::FrameType::shm_release:
        case proto::FrameType::shm_region_gone:
            check_shm_number(frame.fields, frame.type);
            break;
        case proto::FrameType::shm_free:
            check_shm_free(frame.fields);
            break;
        case proto::FrameType::call:
            check_call(frame.fields);
            break;
        case proto::FrameType::answer:
            check_answer(frame.fields);
            break;
        case proto::FrameType::rings:
            check_rings(frame.fields);
            break;
        case proto::FrameType::data:
        case proto::FrameType::data_batch:
            break;  // message_fuzz.cpp
    }
    return 0;
}
