#include "outbox.hpp"

#include <algorithm>

#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::daemon {

namespace {
// Linux's IOV_MAX is 1024; stay below it so one batch is one sendmsg.
constexpr std::size_t max_buffers = 1000;
}  // namespace

void Batch::clear() {
    buffers.clear();
    messages.clear();
    control.clear();
    prefixes.clear();
    bytes = 0;
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
    // Pieces are recorded first and turned into buffers at the end, because appending prefixes may
    // move the prefix buffer.
    struct Piece {
        enum Kind { control, prefix, record } kind;
        std::size_t index;  // control: index in batch.control; prefix: offset; record: index in messages
        std::size_t size;
    };
    std::vector<Piece> pieces;
    while (!control_.empty() && batch.bytes < budget && pieces.size() < max_buffers) {
        batch.bytes += control_.front().size();
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
                ++*source.sent_counter;
            const std::size_t offset = batch.prefixes.size();
            proto::append_data_frame_prefix(batch.prefixes, source.handle, message.record.size());
            pieces.push_back({Piece::prefix, offset, batch.prefixes.size() - offset});
            pieces.push_back({Piece::record, batch.messages.size(), message.record.size()});
            batch.bytes += batch.prefixes.size() - offset + message.record.size();
            batch.messages.push_back(std::move(message));
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
            case Piece::prefix:
                batch.buffers.emplace_back(batch.prefixes.data() + piece.index, piece.size);
                break;
            case Piece::record:
                batch.buffers.emplace_back(batch.messages[piece.index].record.data(), piece.size);
                break;
        }
    }
}

}  // namespace plexus::daemon
