#include "frame_reader.hpp"

#include <algorithm>
#include <cstring>

#include "session_rings.hpp"

namespace plexus::daemon {

namespace {
// How many retired chunks a reader keeps for reuse (at most a few MiB with large frames).
constexpr std::size_t max_spare = 4;
}  // namespace

void FrameReader::make_room(std::size_t needed_total) {
    const std::size_t pending = end_ - begin_;
    const std::size_t want = std::max(needed_total, pending + 1);
    if (last_frame_size_ >= large_frame && pending == 0 && chunk_ && chunk_.use_count() > 1) {
        // In a stream of large frames, the next one starts in a chunk of its own, sized like the
        // last: appended to the chunk a queued frame still holds, its start would have to be
        // copied out again as soon as its length showed it does not fit.
        retire_chunk();
        chunk_ = take_chunk(std::max({chunk_size, want, last_frame_size_}));
        begin_ = end_ = 0;
        return;
    }
    if (chunk_ && chunk_->size - begin_ >= want)
        return;
    if (chunk_ && chunk_.use_count() == 1 && chunk_->size >= want) {
        // Nobody else refers to this chunk: slide the partial frame to the front and reuse it.
        std::memmove(chunk_->data(), chunk_->data() + begin_, pending);
        begin_ = 0;
        end_ = pending;
        return;
    }
    auto fresh = take_chunk(std::max(chunk_size, want));
    if (pending > 0)
        std::memcpy(fresh->data(), chunk_->data() + begin_, pending);
    retire_chunk();
    chunk_ = std::move(fresh);
    begin_ = 0;
    end_ = pending;
}

void FrameReader::retire_chunk() {
    if (!chunk_)
        return;
    if (spare_.size() >= max_spare)
        spare_.erase(spare_.begin());
    spare_.push_back(std::move(chunk_));
}

std::size_t FrameReader::read_space(std::size_t needed_total) const {
    std::size_t space = chunk_->size - end_;
    if (needed_total >= large_frame) {
        // A large frame is read up to its end and no further, so that the next frame does not
        // start inside this chunk (see make_room).
        space = std::min(space, begin_ + needed_total - end_);
    }
    return space;
}

std::shared_ptr<Chunk> FrameReader::take_chunk(std::size_t size) {
    for (auto it = spare_.begin(); it != spare_.end(); ++it) {
        if (it->use_count() == 1 && (*it)->size >= size && (*it)->size <= 4 * size) {
            auto chunk = std::move(*it);
            spare_.erase(it);
            return chunk;
        }
    }
    return std::make_shared<Chunk>(size);
}

ReadOutcome FrameReader::try_next() {
    if (!chunk_)
        return {};
    auto decoded = decoder_.decode({chunk_->data() + begin_, end_ - begin_});
    if (decoded.status == proto::DecodeStatus::frame) {
        InFrame frame{decoded.type, decoded.fields, chunk_};
        begin_ += decoded.used;
        last_frame_size_ = decoded.used;
        return ReadOutcome{std::move(frame), false, false, {}};
    }
    if (decoded.status == proto::DecodeStatus::bad)
        return ReadOutcome{std::nullopt, false, true, decoded.error};
    return {};
}

FrameReader::Step FrameReader::next_step() {
    std::size_t needed = 1;
    if (chunk_) {
        auto decoded = decoder_.decode({chunk_->data() + begin_, end_ - begin_});
        if (decoded.status == proto::DecodeStatus::frame) {
            InFrame frame{decoded.type, decoded.fields, chunk_};
            begin_ += decoded.used;
            last_frame_size_ = decoded.used;
            return {ReadOutcome{std::move(frame), false, false, {}}, {}};
        }
        if (decoded.status == proto::DecodeStatus::bad)
            return {ReadOutcome{std::nullopt, false, true, decoded.error}, {}};
        needed = decoded.needed;
    }
    make_room(needed);
    return {std::nullopt, asio::buffer(chunk_->data() + end_, read_space(needed))};
}

ReadOutcome FrameReader::ended(bool eof, const std::string& error) const {
    if (eof && begin_ == end_)
        return ReadOutcome{std::nullopt, true, false, {}};
    if (eof) {
        return ReadOutcome{
            std::nullopt, false, true,
            "connection closed inside a frame (" + std::to_string(end_ - begin_) + " bytes of it received)"};
    }
    return ReadOutcome{std::nullopt, false, false, error};
}

Task<ReadOutcome> FrameReader::next(ByteStream& stream) {
    for (;;) {
        auto step = next_step();
        if (step.outcome)
            co_return std::move(*step.outcome);
        auto [ec, n] = co_await stream.read_some(step.room);
        if (ec && ByteStream::is_peer_alert(ec))  // it refused us (a revoked certificate): no tampering
            co_return ended(false, "the peer ended the encrypted link: " + ec.message());
        if (ec && ByteStream::is_tls_error(ec)) {
            auto outcome = ended(false, "the encrypted link broke: " + ec.message());
            outcome.tls_refused = true;
            co_return outcome;
        }
        if (ec)
            co_return ended(ec == asio::error::eof, ec.message());
        end_ += n;
    }
}

Task<ReadOutcome> FrameReader::next(SessionRings& rings) {
    for (;;) {
        auto step = next_step();
        if (step.outcome)
            co_return std::move(*step.outcome);
        const auto n = co_await rings.read_some(step.room);
        if (!n && rings.peer_lied())  // an impossible position: the peer broke the protocol
            co_return ReadOutcome{std::nullopt, false, true, n.error().message};
        if (!n)
            co_return ended(false, n.error().message);
        if (*n == 0)
            co_return ended(true, {});
        end_ += *n;
    }
}

}  // namespace plexus::daemon
