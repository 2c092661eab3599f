#include "shm_region.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "framed_connection.hpp"
#include "plexus/proto/errno_text.hpp"
#include "plexus/proto/shm.hpp"

#ifndef F_SEAL_FUTURE_WRITE
#define F_SEAL_FUTURE_WRITE 0x0010  // Linux 5.1; older C library headers lack it
#endif

namespace plexus::daemon {

proto::Result<std::shared_ptr<ShmRegion>> ShmRegion::create(std::uint64_t id, std::size_t size,
                                                            std::weak_ptr<FramedConnection> writer,
                                                            std::shared_ptr<ShmUsage> usage) {
    std::shared_ptr<ShmRegion> region(new ShmRegion(id, size, std::move(writer), std::move(usage)));
    region->writer_fd_ = ::memfd_create("plexus-shm", MFD_CLOEXEC | MFD_ALLOW_SEALING);
    if (region->writer_fd_ < 0)
        return proto::Error{proto::errno_text("memfd_create")};
    if (::ftruncate(region->writer_fd_, static_cast<off_t>(size)) != 0)
        return proto::Error{proto::errno_text("ftruncate")};
    // Sealed before anyone else has it: a client that could shrink the file would make every
    // mapping of the cut pages fault (SIGBUS), the daemon's included. Not yet F_SEAL_SEAL: future
    // writes are sealed once the writer has mapped it (seal_for_readers).
    if (::fcntl(region->writer_fd_, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW) != 0)
        return proto::Error{proto::errno_text("sealing the region")};
    // A second open file description, read-only: what readers get and what the daemon maps.
    const std::string path = "/proc/self/fd/" + std::to_string(region->writer_fd_);
    region->reader_fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (region->reader_fd_ < 0)
        return proto::Error{proto::errno_text("reopening the region read-only")};
    void* mapped = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, region->reader_fd_, 0);
    if (mapped == MAP_FAILED)
        return proto::Error{proto::errno_text("mmap")};
    region->data_ = static_cast<const std::uint8_t*>(mapped);
    region->usage_->bytes += size;
    ++region->usage_->regions;
    return region;
}

ShmRegion::~ShmRegion() {
    // The last slot may go on any reader's thread: each reader hears of it on its own. Ids are
    // never reused, so a reader that hears late cannot take a newer region for this one.
    for (auto& weak : readers_) {
        if (auto reader = weak.lock()) {
            asio::dispatch(reader->executor(), [reader, id = id_] {
                reader->outbox().forget_region(id);
                reader->send(proto::make_shm_number_frame(proto::FrameType::shm_region_gone, id));
            });
        }
    }
    if (data_) {
        ::munmap(const_cast<std::uint8_t*>(data_), size_);
        usage_->bytes -= size_;
        --usage_->regions;
    }
    if (reader_fd_ >= 0)
        ::close(reader_fd_);
    if (writer_fd_ >= 0)
        ::close(writer_fd_);
}

void ShmRegion::add_reader(std::weak_ptr<FramedConnection> reader) {
    std::lock_guard lock(readers_mutex_);
    std::erase_if(readers_, [](const std::weak_ptr<FramedConnection>& r) { return r.expired(); });
    readers_.push_back(std::move(reader));
}

bool ShmRegion::seal_for_readers() {
    if (reader_seal_ == ReaderSeal::unknown) {
        // The writer maps the region when it gets it, before its first data_shm frame; its mapping
        // keeps working after this seal, which only refuses new writable mappings and write()s.
        const int seals = ::fcntl(writer_fd_, F_GET_SEALS);
        const bool sealed = seals >= 0 && (seals & F_SEAL_FUTURE_WRITE) != 0 && (seals & F_SEAL_SHRINK) != 0;
        const bool now = !sealed && seals >= 0 && (seals & F_SEAL_SEAL) == 0 &&
                         ::fcntl(writer_fd_, F_ADD_SEALS, F_SEAL_FUTURE_WRITE | F_SEAL_SEAL) == 0;
        reader_seal_ = sealed || now ? ReaderSeal::sealed : ReaderSeal::impossible;
    }
    return reader_seal_ == ReaderSeal::sealed;
}

void ShmRegion::free(std::uint64_t offset) {
    --usage_->slots;
    // Here on the writer's thread (at once), or on a reader's: then handed to the writer's.
    if (auto writer = writer_.lock())
        asio::dispatch(writer->executor(),
                       [writer, frame = proto::make_shm_free_frame(id_, offset)]() mutable {
                           writer->send(std::move(frame));
                       });
}

Message copy_out_of_shm(const Message& message) {
    const ShmSlot& slot = *message.shm;
    const auto data = *proto::decode_shm_place(message.record);  // checked when it arrived
    const std::size_t size = data.head.size() + slot.length;
    auto chunk = std::make_shared<Chunk>(size);
    std::memcpy(chunk->data(), data.head.data(), data.head.size());
    std::memcpy(chunk->data() + data.head.size(), slot.region->data() + slot.offset, slot.length);
    const proto::ByteView record(chunk->data(), size);
    return Message{std::move(chunk), record, message.seq, 0};
}

}  // namespace plexus::daemon
