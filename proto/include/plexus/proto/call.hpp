#pragma once
// Frames of request/reply (PROTOCOL.md, "Calls"). A call is a message that wants one answer: it
// travels like data (the same carriers, the same monitors, the arbitration of its port), tagged
// with an id that each hop keeps in its own table, so that the answer goes back along the path the
// call came, hop by hop, and every hop can fail it (timeout, a peer gone) without the others.
//     call   = varint handle | varint id | varint timeout_ms | record
//     answer = varint id | u8 outcome | (record when ok; string reason otherwise)
// `handle` is the port (client <-> daemon) or 0 (daemon -> daemon: a link carries one connection).
// `id` is the sender's: the answer carries it back unchanged.

#include <cstdint>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::proto {

/// What became of a call. The CLI maps timeout to exit 3 and every other failure to exit 4.
enum class CallOutcome : std::uint8_t {
    ok = 0,       ///< answered: a record follows
    failed = 1,   ///< the server's handler failed (threw, or answered with an error)
    refused = 2,  ///< not delivered: no server selectable, a monitor or constraint dropped it, busy
    timeout = 3,  ///< no answer within the caller's timeout
    lost = 4,     ///< the server, its daemon or the link went away with the call
};
inline constexpr std::uint8_t max_call_outcome = 4;

/// "ok", "failed", "refused", "timeout", "lost".
std::string_view call_outcome_name(CallOutcome outcome);

/// The longest timeout a call may ask for (a day): a bigger number is refused, not wrapped.
inline constexpr std::uint64_t max_call_timeout_ms = 24ull * 3600 * 1000;

struct CallView {
    std::uint64_t handle = 0;
    std::uint64_t id = 0;
    std::uint64_t timeout_ms = 0;
    ByteView record;  ///< undecoded; checked by whoever takes it
};

/// Appends the header and fields of a call frame whose record (of `record_size` bytes) follows.
void append_call_frame_prefix(Bytes& out, std::uint64_t handle, std::uint64_t id, std::uint64_t timeout_ms,
                              std::size_t record_size);
/// Appends a whole call frame.
void append_call_frame(Bytes& out, std::uint64_t handle, std::uint64_t id, std::uint64_t timeout_ms,
                       ByteView record);
/// Decodes the fields of a call frame; a timeout over max_call_timeout_ms is refused.
Result<CallView> decode_call(ByteView fields);

struct AnswerView {
    std::uint64_t id = 0;
    CallOutcome outcome = CallOutcome::ok;
    ByteView record;          ///< when ok: the reply's record, undecoded
    std::string_view reason;  ///< otherwise: why, for a person
};

/// Appends an answer frame carrying a reply record.
void append_answer_frame(Bytes& out, std::uint64_t id, ByteView record);
/// Appends an answer frame carrying a failure (`outcome` other than ok) and its reason (cut to
/// max_error_reason bytes).
void append_failed_answer_frame(Bytes& out, std::uint64_t id, CallOutcome outcome, std::string_view reason);
/// Decodes the fields of an answer frame.
Result<AnswerView> decode_answer(ByteView fields);

}  // namespace plexus::proto
