// The receiving half of Connection (connection.hpp): reading the socket, with descriptors and
// large payloads, and handing frames to replies, ports and shared-memory regions. Apart from the
// sending half in connection.cpp; the same class, its locks as the header describes them.
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "blob_pool.hpp"
#include "connection.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"

namespace plexus::detail {

void Connection::receive(Clock::time_point deadline, int flags) {
    // One blocking recv with a receive timeout, instead of poll + recv: on the latency path every
    // system call counts. The timeout is only reset when it would overshoot the deadline by more
    // than a millisecond, or wake up far too early, so a loop of read(1s) sets it once.
    if ((flags & MSG_DONTWAIT) == 0) {
        const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now());
        if (left.count() <= 0)
            return;
        // 0 means "no timeout" to the kernel: a first deadline under 2 us must still set one.
        if (receive_timeout_.count() == 0 || receive_timeout_ > left + std::chrono::milliseconds(1) ||
            receive_timeout_ < left / 2) {
            timeval tv{static_cast<time_t>(left.count() / 1000000),
                       static_cast<suseconds_t>(left.count() % 1000000)};
            ::setsockopt(socket_.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
            receive_timeout_ = left;
        }
    }
    if (large_) {
        receive_large_payload(flags);
        return;
    }
    if (in_begin_ == in_end_)
        in_begin_ = in_end_ = 0;
    if (in_.size() - in_end_ < read_chunk / 4) {
        // Slide the unread part to the front, growing only when one frame needs more room.
        std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
        in_end_ -= in_begin_;
        in_begin_ = 0;
        if (in_.size() - in_end_ < read_chunk / 4)
            in_.resize(in_.size() * 2);
    }
    const std::size_t n = receive_into(in_.data() + in_end_, in_.size() - in_end_, flags);
    if (n == 0)
        return;
    in_end_ += n;
    static const proto::FrameDecoder decoder(proto::default_max_frame);
    received_.clear();
    for (;;) {
        auto decoded = decoder.decode({in_.data() + in_begin_, in_end_ - in_begin_});
        if (decoded.status == proto::DecodeStatus::bad) {
            deliver_received();
            fail("bad frame from the daemon: " + decoded.error);
            return;
        }
        if (decoded.status == proto::DecodeStatus::need_more) {
            deliver_received();  // before the tail moves: received_ holds offsets into in_
            if (start_large_payload(decoded.needed))
                return;
            if (decoded.needed > in_.size() - in_begin_) {
                std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
                in_end_ -= in_begin_;
                in_begin_ = 0;
                in_.resize(std::max(in_.size(), decoded.needed));
            }
            return;
        }
        if (decoded.type == proto::FrameType::data) {
            auto data = proto::decode_data(decoded.fields);
            if (!data) {
                deliver_received();
                return fail("bad data frame: " + data.error().message);
            }
            received_.push_back({data->handle, static_cast<std::size_t>(data->record.data() - in_.data()),
                                 data->record.size()});
        } else if (decoded.type == proto::FrameType::data_batch) {
            auto batch = proto::decode_batch(decoded.fields);
            if (!batch) {
                deliver_received();
                return fail(batch.error().message);
            }
            const std::size_t before = received_.size();
            proto::BatchRecords records(batch->records, batch->count);
            while (const auto record = records.next()) {
                received_.push_back(
                    {batch->handle, static_cast<std::size_t>(record->data() - in_.data()), record->size()});
            }
            if (!records.error().empty()) {
                received_.resize(before);  // none of a broken batch is delivered
                deliver_received();
                return fail(records.error());
            }
        } else if (decoded.type == proto::FrameType::data_shm) {
            deliver_received();  // the records before it go first
            receive_shm_data(decoded.fields);
            if (is_broken_.load(std::memory_order_acquire))
                return;
        } else {
            dispatch(decoded.type, decoded.fields);
        }
        in_begin_ += decoded.used;
    }
}

std::size_t Connection::receive_into(std::uint8_t* at, std::size_t room, int flags) {
    const SocketReceived result = socket_.receive(at, room, received_fds_, flags);
    if (result.failure)
        fail(*result.failure);
    return result.bytes;
}

bool Connection::start_large_payload(std::size_t frame_size) {
    const proto::ByteView start(in_.data() + in_begin_, in_end_ - in_begin_);
    auto frame = parse_large_payload_frame(start, frame_size);
    if (!frame)
        return false;
    // Sized (and so zeroed) once: the kernel's copy then writes into pages already there. A
    // recycled buffer (blob_pool.hpp) has its pages already.
    std::vector<std::uint8_t> bytes = take_blob_buffer(frame->payload_size);
    bytes.resize(frame->payload_size);
    large_.emplace(LargePayload{frame->handle,
                                Received{std::move(frame->envelope), Value::binary(std::move(bytes))},
                                nullptr, frame->payload_size});
    large_->at = large_->message.data.get_binary().data();
    // The part of the payload already here (everything in in_ belongs to this frame: it is not whole).
    const std::size_t here = start.size() - frame->payload_offset;
    std::memcpy(large_->at, start.data() + frame->payload_offset, here);
    large_->at += here;
    large_->left -= here;
    in_begin_ = in_end_ = 0;
    return true;
}

void Connection::receive_large_payload(int flags) {
    if (large_->left > 0) {
        const std::size_t n = receive_into(large_->at, large_->left, flags);
        large_->at += n;
        large_->left -= n;
        if (large_->left > 0)
            return;
    }
    std::lock_guard lock(state_mutex_);
    if (!closed_handles_.contains(large_->handle))
        inbox_[large_->handle].push_back(InboxSegment{nullptr, {}, std::move(large_->message)});
    large_.reset();
}

void Connection::deliver_received() {
    if (received_.empty())
        return;
    const std::size_t first = received_.front().offset;
    const std::size_t last = received_.back().offset + received_.back().size;
    auto block = std::make_shared<const proto::Bytes>(in_.begin() + static_cast<std::ptrdiff_t>(first),
                                                      in_.begin() + static_cast<std::ptrdiff_t>(last));
    std::lock_guard lock(state_mutex_);
    std::optional<std::uint64_t> run_handle;
    InboxSegment* run = nullptr;  // the segment of the current run of records for one handle
    for (const auto& data : received_) {
        if (data.handle != run_handle) {
            // Handles are never reused: keep data for any handle not closed, even one whose open
            // reply is still being processed, so nothing that arrives with the reply is lost.
            run_handle = data.handle;
            run = nullptr;
            if (!closed_handles_.contains(data.handle))
                run = &inbox_[data.handle].emplace_back(InboxSegment{block, {}, std::nullopt});
        }
        if (run)
            run->records.emplace_back(block->data() + (data.offset - first), data.size);
    }
    received_.clear();
}

void Connection::dispatch(proto::FrameType type, proto::ByteView fields) {
    switch (type) {
        case proto::FrameType::hello: {
            // Its max_frame bounds what this client may send (Port::send refuses larger messages).
            if (auto hello = proto::decode_hello(fields); hello && hello->max_frame > 0)
                peer_max_frame_.store(hello->max_frame, std::memory_order_relaxed);
            return;
        }
        case proto::FrameType::reply: {
            auto reply = proto::decode_reply(fields);
            if (!reply)
                return fail("bad reply: " + reply.error().message);
            std::lock_guard lock(state_mutex_);
            auto it = replies_.find(reply->id);
            if (it != replies_.end())
                it->second = std::move(*reply);
            return;
        }
        case proto::FrameType::error: {
            const auto reason = proto::decode_error(fields);
            return fail("the daemon reported: " +
                        (reason ? *reason : std::string(proto::as_string_view(fields))));
        }
        case proto::FrameType::shm_region:
        case proto::FrameType::shm_free:
        case proto::FrameType::shm_region_gone:
            return on_shm_frame(type, fields);
        default:
            return fail("unexpected frame type " + proto::frame_type_name(static_cast<std::uint8_t>(type)));
    }
}

void Connection::on_shm_frame(proto::FrameType type, proto::ByteView fields) {
    if (type == proto::FrameType::shm_free) {
        const auto freed = proto::decode_shm_free(fields);
        if (!freed)
            return fail("bad shm_free: " + freed.error().message);
        std::lock_guard lock(shm_mutex_);
        const auto region = writer_regions_.find(freed->first);
        if (region != writer_regions_.end() && region->second->slots.free(freed->second))
            region->second->stalled = false;  // else its port closed meanwhile
        return;
    }
    if (type == proto::FrameType::shm_region_gone) {
        const auto id = proto::decode_shm_number(fields, "region");
        if (!id)
            return fail("bad shm_region_gone: " + id.error().message);
        const auto region = reader_regions_.find(*id);
        if (region != reader_regions_.end()) {
            ::munmap(const_cast<std::uint8_t*>(region->second.data), region->second.size);
            reader_regions_.erase(region);
        }
        return;
    }
    const auto region = proto::decode_shm_region(fields);
    if (!region)
        return fail("bad shm_region: " + region.error().message);
    if (received_fds_.empty())
        return fail("a shm_region frame came without its descriptor");
    const int fd = received_fds_.front();
    received_fds_.pop_front();
    // Readers map regions read-only (the daemon sends them a read-only descriptor, so no reader
    // can write into a writer's slots), and copy payloads out with memcpy: a pread costs twice as
    // much per byte (page-cache look-ups per page). The mapping keeps the region; not the fd.
    const int protection = region->writable ? PROT_READ | PROT_WRITE : PROT_READ;
    void* mapped = ::mmap(nullptr, region->size, protection, MAP_SHARED, fd, 0);
    if (mapped == MAP_FAILED) {
        ::close(fd);
        if (!region->writable)
            return fail(std::string("cannot map a shared-memory region: ") + std::strerror(errno));
        return;  // the request that asked for it finds no region and writes through the socket
    }
    if (!region->writable) {
        ::close(fd);
        auto& entry = reader_regions_[region->region];
        if (entry.data)
            ::munmap(const_cast<std::uint8_t*>(entry.data), entry.size);
        entry =
            ReaderRegion{static_cast<const std::uint8_t*>(mapped), static_cast<std::size_t>(region->size)};
        return;
    }
    std::lock_guard lock(shm_mutex_);
    writer_regions_[region->region] = std::make_unique<WriterRegion>(
        region->region, fd, static_cast<std::uint8_t*>(mapped), static_cast<std::size_t>(region->size));
}

void Connection::receive_shm_data(proto::ByteView fields) {
    const auto data = proto::decode_shm_data(fields);
    if (!data)
        return fail("bad data_shm frame: " + data.error().message);
    // Counted before anything else: the daemon holds the slot until it is released, whatever
    // becomes of the message here.
    unreleased_.fetch_add(1, std::memory_order_relaxed);
    const auto region = reader_regions_.find(data->place.region);
    if (region == reader_regions_.end())
        return fail("data_shm for region " + std::to_string(data->place.region) + ", which was not sent");
    const proto::ShmPlace& place = data->place;
    if (place.offset > region->second.size || place.length > region->second.size - place.offset)
        return fail("data_shm place outside its region");
    {
        std::lock_guard lock(state_mutex_);
        if (closed_handles_.contains(data->handle))
            return;
    }
    const proto::ByteView payload(region->second.data + place.offset, static_cast<std::size_t>(place.length));
    InboxSegment segment;
    // A byte string (an image, a point cloud) is copied straight into the Value the reader gets
    // (and only copied: no zero-fill first); any other payload is put back together as a record,
    // decoded when it is read.
    const auto string_head = parse_byte_string_head(payload);
    if (string_head && string_head->head_size + string_head->length == payload.size()) {
        const auto record = proto::decode_record(data->head);  // checked by decode_shm_data
        std::vector<std::uint8_t> bytes = take_blob_buffer(static_cast<std::size_t>(string_head->length));
        bytes.insert(bytes.end(), payload.begin() + static_cast<std::ptrdiff_t>(string_head->head_size),
                     payload.end());
        segment.whole = Received{Envelope{std::string(record->source), record->seq, record->time_ns},
                                 Value::binary(std::move(bytes))};
    } else {
        auto block = std::make_shared<proto::Bytes>(data->head.size() + payload.size());
        std::memcpy(block->data(), data->head.data(), data->head.size());
        std::memcpy(block->data() + data->head.size(), payload.data(), payload.size());
        segment.records.emplace_back(block->data(), block->size());
        segment.block = std::move(block);
    }
    std::lock_guard lock(state_mutex_);
    if (!closed_handles_.contains(data->handle))
        inbox_[data->handle].push_back(std::move(segment));
}

void Connection::append_releases_locked() {
    if (unreleased_.load(std::memory_order_relaxed) == 0)
        return;  // every write comes here: a load, not a read-modify-write, when there is nothing
    const std::uint64_t count = unreleased_.exchange(0, std::memory_order_relaxed);
    if (count == 0)
        return;
    const auto frame = proto::make_shm_number_frame(proto::FrameType::shm_release, count);
    out_.insert(out_.end(), frame.begin(), frame.end());
}

void Connection::flush_releases() {
    if (unreleased_.load(std::memory_order_relaxed) == 0)
        return;
    std::unique_lock lock(send_mutex_, std::try_to_lock);
    if (!lock.owns_lock())
        return;  // the thread sending now appends them to its next frames
    append_releases_locked();
    // Never a blocking send here: this thread is the reader, and a daemon holding this client
    // back would wait for it to read.
    if (backlog_)
        return;  // the backlog thread sends them with the rest
    send_available_locked();
    if (!out_.empty()) {
        backlog_ = true;
        start_backlog_thread_locked();
        backlog_changed_.notify_one();
    }
}

}  // namespace plexus::detail
