#include "plexus/proto/rings.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

std::size_t RingLayout::ring_bytes_for(std::uint64_t wanted) {
    if (wanted == 0)
        return default_ring_bytes;
    const std::uint64_t bounded = std::clamp<std::uint64_t>(wanted, min_ring_bytes, max_ring_bytes);
    return static_cast<std::size_t>(std::bit_ceil(bounded));
}

std::optional<std::size_t> RingWriter::room() const {
    // Acquire: the consumer's reads of the bytes it freed happened before we write over them.
    const std::uint64_t used =
        tail_.load(std::memory_order_relaxed) - control_->head.load(std::memory_order_acquire);
    if (used > capacity_)
        return std::nullopt;  // the consumer claims to have read what was never written
    return capacity_ - used;
}

std::optional<std::size_t> RingWriter::write_some(const iovec* pieces, std::size_t count, bool& wake) {
    wake = false;
    const auto free = room();
    if (!free)
        return std::nullopt;
    std::size_t left = *free;
    std::size_t written = 0;
    const std::size_t mask = capacity_ - 1;
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    for (std::size_t i = 0; i < count && left > 0; ++i) {
        const auto* from = static_cast<const std::uint8_t*>(pieces[i].iov_base);
        std::size_t size = std::min(pieces[i].iov_len, left);
        left -= size;
        while (size > 0) {
            const std::size_t at = (tail + written) & mask;
            const std::size_t part = std::min(size, capacity_ - at);
            std::memcpy(data_ + at, from, part);
            from += part;
            size -= part;
            written += part;
        }
    }
    if (written == 0)
        return 0;
    tail_.store(tail + written, std::memory_order_relaxed);
    control_->tail.store(tail + written, std::memory_order_release);
    // Against the consumer's prepare_to_wait: either it sees the new tail, or we see its flag.
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (control_->reader_waiting.load(std::memory_order_relaxed) != 0)
        wake = control_->reader_waiting.exchange(0, std::memory_order_relaxed) != 0;
    return written;
}

bool RingWriter::prepare_to_wait() {
    control_->writer_waiting.store(1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_seq_cst);
    const auto free = room();
    if (!free || *free > 0) {  // room, or a lie to report: either way, not a time to sleep
        control_->writer_waiting.store(0, std::memory_order_relaxed);
        return true;
    }
    return false;
}

std::optional<std::size_t> RingReader::available() const {
    const std::uint64_t waiting = control_->tail.load(std::memory_order_acquire) - head_;
    if (waiting > capacity_)
        return std::nullopt;  // the producer claims to have written more than the ring holds
    return static_cast<std::size_t>(waiting);
}

std::optional<std::size_t> RingReader::read_some(std::uint8_t* at, std::size_t room, bool& wake) {
    wake = false;
    const auto waiting = available();
    if (!waiting)
        return std::nullopt;
    const std::size_t n = std::min(*waiting, room);
    if (n == 0)
        return 0;
    const std::size_t mask = capacity_ - 1;
    const std::size_t start = head_ & mask;
    const std::size_t first = std::min(n, capacity_ - start);
    std::memcpy(at, data_ + start, first);
    if (n > first)
        std::memcpy(at + first, data_, n - first);
    head_ += n;
    // Release: our copy is done before the producer may write over these bytes.
    control_->head.store(head_, std::memory_order_release);
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (control_->writer_waiting.load(std::memory_order_relaxed) != 0)
        wake = control_->writer_waiting.exchange(0, std::memory_order_relaxed) != 0;
    return n;
}

bool RingReader::prepare_to_wait() {
    control_->reader_waiting.store(1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_seq_cst);
    const auto waiting = available();
    if (!waiting || *waiting > 0) {
        control_->reader_waiting.store(0, std::memory_order_relaxed);
        return true;
    }
    return false;
}

Bytes make_rings_request(std::uint64_t ring_bytes) {
    Bytes fields;
    append_varint(fields, ring_bytes);
    Bytes frame;
    append_frame_header(frame, FrameType::rings, fields.size());
    frame.insert(frame.end(), fields.begin(), fields.end());
    return frame;
}

Result<std::uint64_t> decode_rings_request(ByteView fields) {
    FieldReader reader(fields);
    const auto bytes = reader.varint("ring_bytes");
    if (!bytes)
        return Error{reader.error()};
    if (!reader.rest().empty())
        return Error{"bytes after the rings request"};
    return *bytes;
}

Bytes make_rings_answer(const RingsAnswer& answer) {
    Bytes fields;
    append_varint(fields, answer.ring_bytes);
    append_string(fields, answer.reason);
    Bytes frame;
    append_frame_header(frame, FrameType::rings, fields.size());
    frame.insert(frame.end(), fields.begin(), fields.end());
    return frame;
}

Result<RingsAnswer> decode_rings_answer(ByteView fields) {
    FieldReader reader(fields);
    const auto bytes = reader.varint("ring_bytes");
    const auto reason = reader.string("reason", 4096);
    if (!bytes || !reason)
        return Error{reader.error()};
    return RingsAnswer{*bytes, std::string(*reason)};
}

}  // namespace plexus::proto
