// The shared-memory rings' byte ring (plexus/proto/rings.hpp) with a hostile other side: a
// RingWriter and a RingReader share one control and one ring of bytes, and between their
// operations the input scribbles whatever the peer process could: the positions, the flags, the
// ring's bytes. The input is a script: its first byte sets the capacity (1 << (byte % 13): 1 to
// 4096 bytes, so that small inputs wrap often), then each operation is one byte (which, % 10)
// followed by its arguments.
//
// Properties, after every operation:
// - the ring's bytes are read and written only inside the ring (guard bytes on both sides of the
//   ring, of the control, and after the room a read is given stay as they were);
// - read_some never returns more than the room it was given nor more than the capacity, and
//   write_some never more than the pieces hold nor more than the capacity;
// - an impossible position is reported as nullopt, and only then: the reader's `tail - head` or
//   the writer's `tail - head` (its own position against the other's, mod 2^64) above the
//   capacity; otherwise the count is what the positions allow;
// - what is read is what the ring held at the places the positions name (a shadow copy of the
//   ring, written by the writer's moves and the scribbles, is the reference), and a write lands
//   where the writer's own tail says;
// - each side publishes its own position (and only its own copy decides: a scribbled tail or head
//   never moves the side that owns it), and a wake-up is asked for exactly when the other side's
//   flag was set, which is then cleared.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <vector>

#include "fuzz_check.hpp"
#include "plexus/proto/rings.hpp"

namespace proto = plexus::proto;

namespace {

constexpr std::size_t guard_size = 64;
constexpr std::uint8_t guard_byte = 0xa7;

/// Reads the script; past its end every read gives zeros (and done() says so).
class Script {
public:
    Script(const std::uint8_t* data, std::size_t size) : data_(data), left_(size) {}
    bool done() const { return left_ == 0; }
    std::uint8_t byte() {
        if (left_ == 0)
            return 0;
        --left_;
        return *data_++;
    }
    std::uint64_t u64() {
        std::uint64_t value = 0;
        for (int i = 0; i < 8; ++i)
            value |= std::uint64_t{byte()} << (8 * i);
        return value;
    }
    /// A size up to about twice the capacity, biased toward the edges: 0, 1, capacity - 1,
    /// capacity, capacity + 1.
    std::size_t size_near(std::size_t capacity) {
        const std::uint8_t kind = byte();
        switch (kind % 6) {
            case 0:
                return 0;
            case 1:
                return 1;
            case 2:
                return capacity - 1;
            case 3:
                return capacity;
            case 4:
                return capacity + 1;
            default:
                return (std::size_t{byte()} << 8 | byte()) % (2 * capacity + 2);
        }
    }
    /// A position a peer might write: a lie near the honest one, or anything at all.
    std::uint64_t position_near(std::uint64_t honest, std::size_t capacity) {
        const std::uint8_t kind = byte();
        const auto delta = static_cast<std::uint64_t>(byte());
        switch (kind % 6) {
            case 0:
                return honest + delta;
            case 1:
                return honest - delta;
            case 2:
                return honest + capacity + delta;
            case 3:
                return honest - capacity - delta;
            case 4:
                return ~std::uint64_t{0} - delta;
            default:
                return u64();
        }
    }

private:
    const std::uint8_t* data_;
    std::size_t left_;
};

/// The control with guard bytes on both sides, as a peer could not reach past it either.
struct GuardedControl {
    alignas(64) std::array<std::uint8_t, guard_size> before;
    proto::RingControl control;
    alignas(64) std::array<std::uint8_t, guard_size> after;
};

bool guard_intact(const std::uint8_t* from, std::size_t size) {
    return std::all_of(from, from + size, [](std::uint8_t b) { return b == guard_byte; });
}

class Harness {
public:
    explicit Harness(std::size_t capacity)
        : capacity_(capacity), bytes_(guard_size + capacity + guard_size, guard_byte), shadow_(capacity, 0) {
        guarded_.before.fill(guard_byte);
        guarded_.after.fill(guard_byte);
        control().tail.store(0);
        control().head.store(0);
        control().writer_waiting.store(0);
        control().reader_waiting.store(0);
        std::fill(ring(), ring() + capacity_, 0);
        writer_ = proto::RingWriter(&control(), ring(), capacity_);
        reader_ = proto::RingReader(&control(), ring(), capacity_);
    }

    void step(Script& script) {
        switch (script.byte() % 10) {
            case 0:
                write(script);
                break;
            case 1:
                read(script);
                break;
            case 2:
                control().tail.store(script.position_near(tail_, capacity_));
                break;
            case 3:
                control().head.store(script.position_near(head_, capacity_));
                break;
            case 4:
                control().reader_waiting.store(static_cast<std::uint32_t>(script.u64()));
                control().writer_waiting.store(static_cast<std::uint32_t>(script.u64()));
                break;
            case 5:
                scribble_bytes(script);
                break;
            case 6:
                reader_waits();
                break;
            case 7:
                writer_waits();
                break;
            case 8:
                look();
                break;
            default:
                // The peer behaves again: the honest positions back, so that the script can go on.
                control().tail.store(tail_);
                control().head.store(head_);
                break;
        }
        check_guards();
        check_ring();
    }

private:
    proto::RingControl& control() { return guarded_.control; }
    std::uint8_t* ring() { return bytes_.data() + guard_size; }

    /// What the reader must find: the bytes between its own head and the published tail, if that
    /// is a possible amount.
    std::optional<std::size_t> readable() {
        const std::uint64_t waiting = control().tail.load() - head_;
        if (waiting > capacity_)
            return std::nullopt;
        return static_cast<std::size_t>(waiting);
    }
    /// What the writer must find room for: the capacity less what the published head leaves unread
    /// of its own tail, if that is a possible amount.
    std::optional<std::size_t> writable() {
        const std::uint64_t used = tail_ - control().head.load();
        if (used > capacity_)
            return std::nullopt;
        return capacity_ - static_cast<std::size_t>(used);
    }

    void write(Script& script) {
        // Up to three pieces, filled from the script (or a counter once it runs out).
        const std::size_t count = script.byte() % 4;
        std::array<std::vector<std::uint8_t>, 3> data;
        std::array<iovec, 3> pieces{};
        std::size_t total = 0;
        for (std::size_t i = 0; i < count; ++i) {
            data[i].resize(script.size_near(capacity_));
            for (auto& b : data[i])
                b = script.done() ? static_cast<std::uint8_t>(counter_++) : script.byte();
            pieces[i] = {data[i].data(), data[i].size()};
            total += data[i].size();
        }
        const auto room = writable();
        const std::uint32_t reader_flag = control().reader_waiting.load();
        bool wake = true;
        const auto n = writer_.write_some(pieces.data(), count, wake);

        PLEXUS_FUZZ_CHECK(n.has_value() == room.has_value());
        if (!n) {
            PLEXUS_FUZZ_CHECK(!wake);
            return;
        }
        PLEXUS_FUZZ_CHECK(*n == std::min(total, *room));
        PLEXUS_FUZZ_CHECK(*n <= capacity_);
        // The bytes land at the writer's own tail, the pieces in order.
        std::size_t at = 0;
        for (std::size_t i = 0; i < count && at < *n; ++i) {
            for (std::size_t j = 0; j < data[i].size() && at < *n; ++j, ++at)
                shadow_[(tail_ + at) & (capacity_ - 1)] = data[i][j];
        }
        if (*n == 0) {
            PLEXUS_FUZZ_CHECK(!wake);
            return;
        }
        tail_ += *n;
        PLEXUS_FUZZ_CHECK(control().tail.load() == tail_);
        PLEXUS_FUZZ_CHECK(wake == (reader_flag != 0));
        if (reader_flag != 0)
            PLEXUS_FUZZ_CHECK(control().reader_waiting.load() == 0);
    }

    void read(Script& script) {
        const std::size_t room = script.size_near(capacity_);
        std::vector<std::uint8_t> out(room + guard_size, guard_byte);
        const auto waiting = readable();
        const std::uint32_t writer_flag = control().writer_waiting.load();
        const std::uint64_t published_tail = control().tail.load();
        bool wake = true;
        const auto n = reader_.read_some(out.data(), room, wake);

        PLEXUS_FUZZ_CHECK(n.has_value() == waiting.has_value());
        // Nothing is written past what was read, let alone past the room.
        PLEXUS_FUZZ_CHECK(guard_intact(out.data() + (n ? *n : 0), out.size() - (n ? *n : 0)));
        if (!n) {
            PLEXUS_FUZZ_CHECK(!wake);
            return;
        }
        PLEXUS_FUZZ_CHECK(*n == std::min(*waiting, room));
        PLEXUS_FUZZ_CHECK(*n <= room && *n <= capacity_);
        for (std::size_t i = 0; i < *n; ++i)
            PLEXUS_FUZZ_CHECK(out[i] == shadow_[(head_ + i) & (capacity_ - 1)]);
        PLEXUS_FUZZ_CHECK(control().tail.load() == published_tail);  // the reader never moves the tail
        if (*n == 0) {
            PLEXUS_FUZZ_CHECK(!wake);
            return;
        }
        head_ += *n;
        PLEXUS_FUZZ_CHECK(control().head.load() == head_);
        PLEXUS_FUZZ_CHECK(wake == (writer_flag != 0));
        if (writer_flag != 0)
            PLEXUS_FUZZ_CHECK(control().writer_waiting.load() == 0);
    }

    void scribble_bytes(Script& script) {
        const std::size_t at = (std::size_t{script.byte()} << 8 | script.byte()) & (capacity_ - 1);
        const std::size_t count = std::min<std::size_t>(script.byte() % 16 + 1, capacity_);
        for (std::size_t i = 0; i < count; ++i) {
            const std::uint8_t b = script.byte();
            ring()[(at + i) & (capacity_ - 1)] = b;
            shadow_[(at + i) & (capacity_ - 1)] = b;
        }
    }

    void reader_waits() {
        const auto waiting = readable();
        const bool look_again = reader_.prepare_to_wait();
        // Sleep only on an empty ring; a lie is never a reason to sleep (the caller must see it).
        PLEXUS_FUZZ_CHECK(look_again == (!waiting || *waiting > 0));
        PLEXUS_FUZZ_CHECK(control().reader_waiting.load() == (look_again ? 0u : 1u));
        if (!look_again)
            reader_.done_waiting();
        PLEXUS_FUZZ_CHECK(control().reader_waiting.load() == 0);
    }

    void writer_waits() {
        const auto room = writable();
        const bool look_again = writer_.prepare_to_wait();
        PLEXUS_FUZZ_CHECK(look_again == (!room || *room > 0));
        PLEXUS_FUZZ_CHECK(control().writer_waiting.load() == (look_again ? 0u : 1u));
        if (!look_again)
            writer_.done_waiting();
        PLEXUS_FUZZ_CHECK(control().writer_waiting.load() == 0);
    }

    void look() {
        PLEXUS_FUZZ_CHECK(reader_.available() == readable());
        PLEXUS_FUZZ_CHECK(writer_.room() == writable());
        if (const auto room = writer_.room())
            PLEXUS_FUZZ_CHECK(*room <= capacity_);
        if (const auto waiting = reader_.available())
            PLEXUS_FUZZ_CHECK(*waiting <= capacity_);
    }

    void check_ring() { PLEXUS_FUZZ_CHECK(std::equal(shadow_.begin(), shadow_.end(), ring())); }

    void check_guards() {
        PLEXUS_FUZZ_CHECK(guard_intact(bytes_.data(), guard_size));
        PLEXUS_FUZZ_CHECK(guard_intact(ring() + capacity_, guard_size));
        PLEXUS_FUZZ_CHECK(guard_intact(guarded_.before.data(), guard_size));
        PLEXUS_FUZZ_CHECK(guard_intact(guarded_.after.data(), guard_size));
    }

    std::size_t capacity_;
    std::vector<std::uint8_t> bytes_;   ///< guard | ring | guard
    std::vector<std::uint8_t> shadow_;  ///< what the ring must hold
    GuardedControl guarded_;
    proto::RingWriter writer_;
    proto::RingReader reader_;
    std::uint64_t tail_ = 0;  ///< the writer's own position, as the model counts it
    std::uint64_t head_ = 0;  ///< the reader's own position, as the model counts it
    std::uint8_t counter_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0)
        return 0;
    Script script(data, size);
    Harness harness(std::size_t{1} << (script.byte() % 13));
    // Bounded, so that a long input cannot make one run slow (at most 4096-byte rings, 3 pieces).
    for (int steps = 0; steps < 4096 && !script.done(); ++steps)
        harness.step(script);
    return 0;
}
