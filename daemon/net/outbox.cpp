#include "outbox.hpp"

#include <algorithm>

#include "call_table.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"
#include "plexus/proto/varint.hpp"
#include "shm_region.hpp"

namespace plexus::daemon {

namespace {
// Linux's IOV_MAX is 1024; stay below it so one batch is one sendmsg.
constexpr std::size_t max_buffers = 1000;
// Records smaller than this are copied into the batch: a copy of a few KiB costs less than a buffer
// of its own in the system call and the reference that keeps its chunk alive.
constexpr std::size_t copy_below = 4096;
// Descriptors sent with one batch; the kernel takes at most 253 (SCM_MAX_FD) per message, and a
// batch adds at most one per frame before it looks at this bound again.
constexpr std::size_t max_fds = 200;
}  // namespace

void Batch::clear() {
    buffers.clear();
    messages.clear();
    control.clear();
    flat.clear();
    bytes = 0;
    largest = 0;
    fds.clear();
    regions.clear();
    keep.clear();
    then_rings = false;
}

void Outbox::push_writer_region(std::shared_ptr<const ShmRegion> region) {
    auto frame = proto::make_shm_region_frame({region->id(), region->size(), true});
    control_bytes_ += frame.size();
    control_.push_back({std::move(frame), std::move(region)});
}

void Outbox::push_rings_answer(proto::Bytes frame, std::vector<int> fds, std::shared_ptr<const void> keep) {
    control_bytes_ += frame.size();
    control_.push_back({std::move(frame), nullptr, std::move(fds), std::move(keep), true});
}

bool Outbox::release(std::uint64_t count) {
    if (count > lent_.size())
        return false;
    lent_.erase(lent_.begin(), lent_.begin() + static_cast<std::ptrdiff_t>(count));
    return true;
}

bool Outbox::start_call_frame(Batch& batch, std::uint64_t handle, const Message& message) {
    CallTicket& ticket = *message.call;
    const std::uint64_t left = ticket.timeout_left_ms();
    if (left == 0) {
        ticket.set_drop_reason("its deadline passed while it waited in a queue");
        return false;
    }
    proto::append_call_frame_prefix(batch.flat, handle, ticket.id(), left, message.record.size());
    ticket.hand_on();
    // The only CallRoutes there is: the daemon's call table. It now waits for the answer on this
    // socket, and fails the call if this socket closes first.
    if (auto routes = ticket.routes())
        static_cast<CallTable&>(*routes).handed_on(ticket.id(), owner_.lock());
    return true;
}

void Outbox::add_shm_message(Batch& batch, std::uint64_t handle, Message message) {
    const auto& region = message.shm->region;
    if (!regions_sent_.contains(region->id())) {
        regions_sent_.insert(region->id());
        region->add_reader(owner_);
        const auto frame = proto::make_shm_region_frame({region->id(), region->size(), false});
        batch.flat.insert(batch.flat.end(), frame.begin(), frame.end());
        batch.fds.push_back(region->reader_fd());
        batch.regions.push_back(region);
    }
    proto::append_shm_frame_prefix(batch.flat, handle, message.record.size());
    batch.flat.insert(batch.flat.end(), message.record.begin(), message.record.end());
    lent_.push_back(std::move(message.shm));
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
    while (!control_.empty() && batch.bytes < budget && pieces.size() < max_buffers &&
           batch.fds.size() < max_fds) {
        ControlFrame& frame = control_.front();
        batch.bytes += frame.bytes.size();
        control_bytes_ -= frame.bytes.size();
        pieces.push_back({Piece::control, batch.control.size(), frame.bytes.size()});
        if (frame.writer_region) {
            batch.fds.push_back(frame.writer_region->writer_fd());
            batch.regions.push_back(std::move(frame.writer_region));
        }
        batch.fds.insert(batch.fds.end(), frame.fds.begin(), frame.fds.end());
        if (frame.keep)
            batch.keep.push_back(std::move(frame.keep));
        const bool then_rings = frame.then_rings;
        batch.control.push_back(std::move(frame.bytes));
        control_.pop_front();
        if (then_rings) {
            // The last frame on the socket: what follows is written into the rings.
            batch.then_rings = true;
            break;
        }
    }
    if (batch.then_rings) {
        for (const auto& piece : pieces)
            batch.buffers.emplace_back(batch.control[piece.index].data(), piece.size);
        return;
    }
    // Priorities once per batch (a source's may change between batches, not within one).
    priorities_.assign(sources_.size(), 0);
    for (std::size_t i = 0; i < sources_.size(); ++i) {
        if (sources_[i].priority)
            priorities_[i] = sources_[i].priority();
    }
    bool progress = true;
    while (progress && batch.bytes < budget && pieces.size() + 2 <= max_buffers &&
           batch.fds.size() < max_fds && !sources_.empty()) {
        progress = false;
        // Each round serves only the highest priority that has messages.
        int top = -1;
        for (std::size_t i = 0; i < sources_.size(); ++i) {
            if (!sources_[i].queue->empty())
                top = std::max(top, priorities_[i]);
        }
        for (std::size_t step = 0; step < sources_.size(); ++step) {
            const std::size_t index = (next_source_ + step) % sources_.size();
            auto& source = sources_[index];
            if (source.queue->empty() || priorities_[index] != top)
                continue;
            const bool was_full = source.queue->full();
            Message message = source.queue->pop();
            if (message.shm && !regions_sent_.contains(message.shm->region->id()) &&
                regions_sent_.size() >= max_regions) {
                message = copy_out_of_shm(message);
                if (on_shm_copy_)
                    on_shm_copy_();
            }
            if (source.sent_counter)
                *source.sent_counter += message.count();
            const std::size_t offset = batch.flat.size();
            const std::size_t record_size = message.record.size();
            batch.largest = std::max(batch.largest, record_size);
            if (message.shm) {
                // Only the place of its payload is sent: the payload stays in shared memory.
                add_shm_message(batch, source.handle, std::move(message));
                append_flat(offset);
            } else if (message.call && !start_call_frame(batch, source.handle, message)) {
                // Its deadline passed while it waited here: the caller has been told; not sent.
            } else {
                if (message.call) {
                    // start_call_frame wrote its frame's head
                } else if (message.batch == 0) {
                    proto::append_data_frame_prefix(batch.flat, source.handle, record_size);
                } else {
                    proto::append_batch_frame_prefix(batch.flat, source.handle, message.batch, record_size);
                }
                if (record_size < copy_below) {
                    batch.flat.insert(batch.flat.end(), message.record.begin(), message.record.end());
                    append_flat(offset);
                } else {
                    append_flat(offset);
                    pieces.push_back({Piece::record, batch.messages.size(), record_size});
                    batch.messages.push_back(std::move(message));
                    batch.bytes += record_size;
                }
            }
            batch.bytes += batch.flat.size() - offset;
            if (was_full && !source.queue->full() && on_space_)
                on_space_();
            progress = true;
            if (batch.bytes >= budget || pieces.size() + 2 > max_buffers || batch.fds.size() >= max_fds)
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
