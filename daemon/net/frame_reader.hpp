#pragma once
// Threading: one io_context thread; one FrameReader per socket.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../core/message.hpp"
#include "asio.hpp"
#include "byte_stream.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::daemon {

class SessionRings;

struct InFrame {
    proto::FrameType type{};
    proto::ByteView fields;
    std::shared_ptr<const Chunk> storage;  ///< keeps `fields` valid; share it to keep a record alive
    /// Records of a data_batch frame already delivered: a batch is cut at a strict queue's bound
    /// and the rest waits for room.
    std::uint32_t delivered_records = 0;
    /// A data_shm frame turned into its message (its slot held) the first time it was looked at,
    /// kept while it waits for room so that the slot is not freed under the writer.
    std::optional<Message> resolved{};
};

struct ReadOutcome {
    std::optional<InFrame> frame{};
    bool clean_close = false;     ///< the peer closed between frames
    bool protocol_error = false;  ///< the peer broke the protocol: `error` says how
    std::string error;
    bool tls_refused = false;  ///< an encrypted link's record failed its check: `error` says how
};

/// Reads frames into chunks that queued messages can share, so a record is never copied after the
/// socket read. A chunk is reused only when no message refers to it any more.
class FrameReader {
public:
    explicit FrameReader(std::size_t max_body) : decoder_(max_body) {}
    Task<ReadOutcome> next(ByteStream& stream);
    /// The same, from the ring a client writes into (session_rings.hpp).
    Task<ReadOutcome> next(SessionRings& rings);
    /// The next frame if it is already buffered, or a protocol error; an empty outcome when more
    /// bytes are needed. Saves a coroutine call per frame when a read brought many.
    ReadOutcome try_next();
    /// Bytes received and not yet consumed (for tests of truncation).
    std::size_t buffered() const { return end_ - begin_; }

private:
    /// A frame (or a protocol error) from what is buffered, or else the room the next read fills.
    struct Step {
        std::optional<ReadOutcome> outcome;
        asio::mutable_buffer room;
    };
    Step next_step();
    /// The outcome of a stream that ended (`eof`: the peer closed) or failed.
    ReadOutcome ended(bool eof, const std::string& error) const;
    void make_room(std::size_t needed_total);
    /// Moves the current chunk to the spares (reused once nothing refers to it).
    void retire_chunk();
    /// How much the next socket read may bring into the current chunk.
    std::size_t read_space(std::size_t needed_total) const;
    std::shared_ptr<Chunk> take_chunk(std::size_t size);
    static constexpr std::size_t chunk_size = 64 * 1024;
    /// Frames at least this large are read to their end only, each into a chunk of its own.
    static constexpr std::size_t large_frame = 64 * 1024;
    proto::FrameDecoder decoder_;
    std::shared_ptr<Chunk> chunk_;
    /// Chunks handed out earlier, reused once no message refers to them: a stream of large frames
    /// would otherwise cost a fresh allocation (and its page faults) per frame.
    std::vector<std::shared_ptr<Chunk>> spare_;
    std::size_t begin_ = 0;
    std::size_t end_ = 0;
    std::size_t last_frame_size_ = 0;  ///< bytes of the last whole frame returned
};

}  // namespace plexus::daemon
