#include "outbox.hpp"

#include <algorithm>

#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::daemon {

namespace {
// Linux's IOV_MAX is 1024; stay below it so one batch is one sendmsg.
constexpr std::size_t max_buffers = 1000;
// Records smaller than this are copied into the batch: a copy of a few KiB costs less than a buffer
// of its own in the system call and the reference that keeps its chunk alive.
constexpr std::size_t copy_below = 4096;
}  // namespace

void Batch::clear() {
    buffers.clear();
    messages.clear();
    control.clear();
    flat.clear();
    bytes = 0;
    largest = 0;
}

void Outbox::remove_source(std::uint64_t handle) {
    std::erase_if(sources_, [&](const OutSource& s) { return s.handle == handle; });
    next_source_ = 0;
}

bool Outbox::empty() const {
    return control_.empty() && std::none_of(sources_.begin(), sources_.end(),
                                            [](const OutSource& s) { return !s.queue->empty(); });
}

void Outbox::fill(Batch& batch, std::size_t budget) {
    // Pieces are recorded first and turned into buffers at the end, because appending to `flat` may
    // move it. Consecutive flat pieces merge into one.
    struct Piece {
        enum Kind { control, flat, record } kind;
        std::size_t index;  // control: index in batch.control; flat: offset; record: index in messages
        std::size_t size;
    };
    std::vector<Piece> pieces;
    auto append_flat = [&](std::size_t offset) {
        const std::size_t size = batch.flat.size() - offset;
        if (!pieces.empty() && pieces.back().kind == Piece::flat)
            pieces.back().size += size;
        else
            pieces.push_back({Piece::flat, offset, size});
    };
    while (!control_.empty() && batch.bytes < budget && pieces.size() < max_buffers) {
        batch.bytes += control_.front().size();
        control_bytes_ -= control_.front().size();
        pieces.push_back({Piece::control, batch.control.size(), control_.front().size()});
        batch.control.push_back(std::move(control_.front()));
        control_.pop_front();
    }
    bool progress = true;
    while (progress && batch.bytes < budget && pieces.size() + 2 <= max_buffers && !sources_.empty()) {
        progress = false;
        for (std::size_t step = 0; step < sources_.size(); ++step) {
            auto& source = sources_[(next_source_ + step) % sources_.size()];
            if (source.queue->empty())
                continue;
            const bool was_full = source.queue->full();
            Message message = source.queue->pop();
            if (source.sent_counter)
                *source.sent_counter += message.count();
            const std::size_t offset = batch.flat.size();
            const std::size_t record_size = message.record.size();
            batch.largest = std::max(batch.largest, record_size);
            if (message.batch == 0)
                proto::append_data_frame_prefix(batch.flat, source.handle, record_size);
            else
                proto::append_batch_frame_prefix(batch.flat, source.handle, message.batch, record_size);
            if (record_size < copy_below) {
                batch.flat.insert(batch.flat.end(), message.record.begin(), message.record.end());
                append_flat(offset);
            } else {
                append_flat(offset);
                pieces.push_back({Piece::record, batch.messages.size(), record_size});
                batch.messages.push_back(std::move(message));
                batch.bytes += record_size;
            }
            batch.bytes += batch.flat.size() - offset;
            if (was_full && !source.queue->full() && on_space_)
                on_space_();
            progress = true;
            if (batch.bytes >= budget || pieces.size() + 2 > max_buffers)
                break;
        }
        next_source_ = sources_.empty() ? 0 : (next_source_ + 1) % sources_.size();
    }
    for (const auto& piece : pieces) {
        switch (piece.kind) {
            case Piece::control:
                batch.buffers.emplace_back(batch.control[piece.index].data(), piece.size);
                break;
            case Piece::flat:
                batch.buffers.emplace_back(batch.flat.data() + piece.index, piece.size);
                break;
            case Piece::record:
                batch.buffers.emplace_back(batch.messages[piece.index].record.data(), piece.size);
                break;
        }
    }
}

}  // namespace plexus::daemon
