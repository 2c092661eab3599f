// A shared-memory region as the daemon makes it (net/shm_region.hpp): nobody can resize it, and
// once sealed for readers nobody but the writer's own mapping can write into it.
#include "../../../daemon/net/shm_region.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace plexus::daemon {
namespace {

constexpr std::size_t size = 1024 * 1024;

std::shared_ptr<ShmRegion> make_region(const std::shared_ptr<ShmUsage>& usage) {
    auto region = ShmRegion::create(1, size, {}, usage);
    EXPECT_TRUE(region.ok()) << region.error().message;
    return *region;
}

/// What a reader could try: reopen its read-only descriptor read-write and map it writable.
bool reader_can_write(int reader_fd) {
    const std::string path = "/proc/self/fd/" + std::to_string(reader_fd);
    const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0)
        return false;
    void* mapped = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    const char byte = 'x';
    const bool writes = ::pwrite(fd, &byte, 1, 0) == 1;
    ::close(fd);
    if (mapped == MAP_FAILED)
        return writes;
    ::munmap(mapped, size);
    return true;
}

TEST(ShmRegion_test, NobodyCanResizeARegion) {
    auto usage = std::make_shared<ShmUsage>();
    auto region = make_region(usage);
    EXPECT_NE(::ftruncate(region->writer_fd(), size / 2), 0) << "a client could shrink the region";
    EXPECT_NE(::ftruncate(region->writer_fd(), size * 2), 0) << "a client could grow the region";
    EXPECT_EQ(usage->bytes, size);
    EXPECT_EQ(usage->regions, 1u);
    region.reset();
    EXPECT_EQ(usage->bytes, 0u);
    EXPECT_EQ(usage->regions, 0u);
}

TEST(ShmRegion_test, OnceSealedForReadersOnlyTheWritersMappingWrites) {
    auto usage = std::make_shared<ShmUsage>();
    auto region = make_region(usage);
    // The writer maps its descriptor when it gets the region, before it writes anything.
    void* mapped = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, region->writer_fd(), 0);
    ASSERT_NE(mapped, MAP_FAILED);
    auto* writer = static_cast<std::uint8_t*>(mapped);
    EXPECT_TRUE(reader_can_write(region->reader_fd())) << "the attack this seal is for no longer exists?";

    ASSERT_TRUE(region->seal_for_readers());

    EXPECT_FALSE(reader_can_write(region->reader_fd())) << "a reader could write into the writer's slots";
    std::memcpy(writer + 100, "payload", 7);  // the writer's mapping still works
    EXPECT_EQ(std::memcmp(region->data() + 100, "payload", 7), 0);
    EXPECT_TRUE(region->seal_for_readers()) << "asking again must not fail";
    ::munmap(mapped, size);
}

}  // namespace
}  // namespace plexus::daemon
