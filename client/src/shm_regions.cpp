#include "shm_regions.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "blob_pool.hpp"
#include "large_payload.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::detail {

WriterRegion::~WriterRegion() {
    ::munmap(data, size);
    ::close(fd);
}

ShmRegions::~ShmRegions() = default;

void ShmRegions::enable(bool on) {
    std::lock_guard lock(mutex_);
    enabled_ = on;
}

std::optional<std::shared_ptr<WriterRegion>> ShmRegions::writer_region(std::uint64_t handle) {
    std::lock_guard lock(mutex_);
    if (!enabled_)
        return nullptr;
    const auto known = port_regions_.find(handle);
    if (known == port_regions_.end())
        return std::nullopt;
    if (!known->second)
        return nullptr;
    const auto region = writer_regions_.find(*known->second);
    return region == writer_regions_.end() ? nullptr : region->second;
}

std::shared_ptr<WriterRegion> ShmRegions::assign(std::uint64_t handle, std::optional<std::uint64_t> id) {
    std::lock_guard lock(mutex_);
    auto& known = port_regions_[handle];
    known.reset();
    if (!id)
        return nullptr;
    const auto region = writer_regions_.find(*id);
    if (region == writer_regions_.end())
        return nullptr;
    known = id;
    return region->second;
}

std::optional<std::size_t> ShmRegions::allocate(WriterRegion& region, std::size_t length,
                                                std::chrono::steady_clock::duration wait) {
    std::unique_lock lock(mutex_);
    std::optional<std::size_t> offset = region.slots.allocate(length);
    if (offset || region.stalled)
        return offset;
    // Full, perhaps only because the daemon's frees for earlier slots wait unread in the socket:
    // the receiving thread takes them first (it needs this lock for them: not held meanwhile).
    lock.unlock();
    demand_.poll(wait);
    lock.lock();
    offset = region.slots.allocate(length);
    if (offset || region.stalled)
        return offset;
    // Still full: the readers are behind, or their releases (and the daemon's frees) are still on
    // the way. Waiting for them costs less than the socket path; a region that stays full past the
    // wait is marked stalled and writes go through the socket, without waiting, until a slot comes
    // free. The receiving thread reads the frees meanwhile (asked to by the demand).
    const auto deadline = std::chrono::steady_clock::now() + wait;
    demand_.add(deadline);
    const bool room = freed_.wait_until(lock, deadline, [&] {
        offset = region.slots.allocate(length);
        return offset.has_value();
    });
    demand_.remove();
    if (!room)
        region.stalled = true;
    return offset;
}

void ShmRegions::forget(std::uint64_t handle) {
    // Frees that still come for the region are ignored.
    std::lock_guard lock(mutex_);
    const auto known = port_regions_.find(handle);
    if (known == port_regions_.end())
        return;
    if (known->second)
        writer_regions_.erase(*known->second);
    port_regions_.erase(known);
}

std::optional<std::string> ShmRegions::on_frame(proto::FrameType type, proto::ByteView fields,
                                                std::deque<int>& fds) {
    if (type == proto::FrameType::shm_free) {
        const auto freed = proto::decode_shm_free(fields);
        if (!freed)
            return "bad shm_free: " + freed.error().message;
        {
            std::lock_guard lock(mutex_);
            const auto region = writer_regions_.find(freed->first);
            if (region == writer_regions_.end() || !region->second->slots.free(freed->second))
                return std::nullopt;  // its port closed meanwhile
            region->second->stalled = false;
        }
        freed_.notify_all();
        return std::nullopt;
    }
    if (type == proto::FrameType::shm_region_gone) {
        const auto id = proto::decode_shm_number(fields, "region");
        if (!id)
            return "bad shm_region_gone: " + id.error().message;
        reader_regions_.erase(*id);  // unmapped once no lease of it is left
        return std::nullopt;
    }
    const auto region = proto::decode_shm_region(fields);
    if (!region)
        return "bad shm_region: " + region.error().message;
    if (fds.empty())
        return "a shm_region frame came without its descriptor";
    const int fd = fds.front();
    fds.pop_front();
    // Readers map regions read-only (the daemon sends them a read-only descriptor, so no reader
    // can write into a writer's slots), and copy payloads out with memcpy: a pread costs twice as
    // much per byte (page-cache look-ups per page). The mapping keeps the region; not the fd.
    const int protection = region->writable ? PROT_READ | PROT_WRITE : PROT_READ;
    void* mapped = ::mmap(nullptr, region->size, protection, MAP_SHARED, fd, 0);
    if (mapped == MAP_FAILED) {
        ::close(fd);
        if (!region->writable)
            return std::string("cannot map a shared-memory region: ") + std::strerror(errno);
        return std::nullopt;  // the request that asked for it finds no region and writes through the socket
    }
    if (!region->writable) {
        ::close(fd);
        reader_regions_[region->region] = std::make_shared<const ReaderMapping>(
            static_cast<const std::uint8_t*>(mapped), static_cast<std::size_t>(region->size));
        return std::nullopt;
    }
    std::lock_guard lock(mutex_);
    writer_regions_[region->region] = std::make_shared<WriterRegion>(
        region->region, fd, static_cast<std::uint8_t*>(mapped), static_cast<std::size_t>(region->size));
    return std::nullopt;
}

std::optional<std::string> ShmRegions::check(const proto::ShmDataView& data) const {
    const auto region = reader_regions_.find(data.place.region);
    if (region == reader_regions_.end())
        return "data_shm for region " + std::to_string(data.place.region) + ", which was not sent";
    const proto::ShmPlace& place = data.place;
    if (place.offset > region->second->size || place.length > region->second->size - place.offset)
        return "data_shm place outside its region";
    return std::nullopt;
}

InboxSegment ShmRegions::lease(const proto::ShmDataView& data, std::shared_ptr<ReleaseBook> book,
                               std::uint64_t ticket) const {
    const auto& mapping = reader_regions_.at(data.place.region);
    const proto::ByteView payload(mapping->data + data.place.offset,
                                  static_cast<std::size_t>(data.place.length));
    const auto record = proto::decode_record(data.head);  // checked by decode_shm_data
    InboxSegment segment;
    segment.lease = std::make_shared<ShmLease>(
        mapping, payload, Envelope{std::string(record->source), record->seq, record->time_ns},
        std::move(book), ticket);
    return segment;
}

Received ShmRegions::copy_out(const ShmLease& lease) {
    const proto::ByteView payload = lease.payload;
    // A byte string (an image, a point cloud) is copied straight into the Value the reader gets
    // (and only copied: no zero-fill first); any other payload is decoded from where it is.
    const auto string_head = parse_byte_string_head(payload);
    if (string_head && string_head->head_size + string_head->length == payload.size()) {
        std::vector<std::uint8_t> bytes = take_blob_buffer(static_cast<std::size_t>(string_head->length));
        bytes.insert(bytes.end(), payload.begin() + static_cast<std::ptrdiff_t>(string_head->head_size),
                     payload.end());
        return Received{lease.envelope, Value::binary(std::move(bytes))};
    }
    // The writer can change its slot while this decodes: a copy first, so the decoder sees one value.
    const proto::Bytes copy(payload.begin(), payload.end());
    auto data = proto::decode_cbor(copy);
    if (!data)
        throw Error(ErrorCode::refused,
                    "bad payload from " + lease.envelope.source + ": " + data.error().message);
    return Received{lease.envelope, std::move(*data)};
}

void ShmRegions::give_back(WriterRegion& region, std::size_t offset) {
    {
        std::lock_guard lock(mutex_);
        region.slots.free(offset);
        region.stalled = false;
    }
    freed_.notify_all();
}

}  // namespace plexus::detail
