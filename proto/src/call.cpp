#include "plexus/proto/call.hpp"

#include <algorithm>

#include "plexus/proto/varint.hpp"

namespace plexus::proto {

std::string_view call_outcome_name(CallOutcome outcome) {
    switch (outcome) {
        case CallOutcome::ok:
            return "ok";
        case CallOutcome::failed:
            return "failed";
        case CallOutcome::refused:
            return "refused";
        case CallOutcome::timeout:
            return "timeout";
        case CallOutcome::lost:
            return "lost";
    }
    return "unknown";
}

void append_call_frame_prefix(Bytes& out, std::uint64_t handle, std::uint64_t id, std::uint64_t timeout_ms,
                              std::size_t record_size) {
    append_frame_header(out, FrameType::call,
                        varint_size(handle) + varint_size(id) + varint_size(timeout_ms) + record_size);
    append_varint(out, handle);
    append_varint(out, id);
    append_varint(out, timeout_ms);
}

void append_call_frame(Bytes& out, std::uint64_t handle, std::uint64_t id, std::uint64_t timeout_ms,
                       ByteView record) {
    append_call_frame_prefix(out, handle, id, timeout_ms, record.size());
    out.insert(out.end(), record.begin(), record.end());
}

Result<CallView> decode_call(ByteView fields) {
    FieldReader reader(fields);
    const auto handle = reader.varint("handle");
    const auto id = reader.varint("call id");
    const auto timeout = reader.varint("timeout");
    if (!handle || !id || !timeout)
        return Error{reader.error()};
    if (*timeout > max_call_timeout_ms)
        return Error{"call timeout " + std::to_string(*timeout) + " ms exceeds the limit of " +
                     std::to_string(max_call_timeout_ms) + " ms"};
    return CallView{*handle, *id, *timeout, reader.rest()};
}

void append_answer_frame(Bytes& out, std::uint64_t id, ByteView record) {
    append_frame_header(out, FrameType::answer, varint_size(id) + 1 + record.size());
    append_varint(out, id);
    out.push_back(static_cast<std::uint8_t>(CallOutcome::ok));
    out.insert(out.end(), record.begin(), record.end());
}

void append_failed_answer_frame(Bytes& out, std::uint64_t id, CallOutcome outcome, std::string_view reason) {
    reason = reason.substr(0, std::min(reason.size(), max_error_reason));
    append_frame_header(out, FrameType::answer,
                        varint_size(id) + 1 + varint_size(reason.size()) + reason.size());
    append_varint(out, id);
    out.push_back(static_cast<std::uint8_t>(outcome));
    append_varint(out, reason.size());
    out.insert(out.end(), reason.begin(), reason.end());
}

Result<AnswerView> decode_answer(ByteView fields) {
    FieldReader reader(fields);
    const auto id = reader.varint("call id");
    const auto outcome = reader.byte("outcome");
    if (!id || !outcome)
        return Error{reader.error()};
    if (*outcome > max_call_outcome)
        return Error{"unknown call outcome " + std::to_string(*outcome)};
    AnswerView answer{*id, static_cast<CallOutcome>(*outcome), {}, {}};
    if (answer.outcome == CallOutcome::ok) {
        answer.record = reader.rest();
        return answer;
    }
    const auto reason = reader.string("reason", max_error_reason);
    if (!reason)
        return Error{reader.error()};
    if (!reader.rest().empty())
        return Error{"answer: " + std::to_string(reader.rest().size()) + " bytes after the reason"};
    answer.reason = *reason;
    return answer;
}

}  // namespace plexus::proto
