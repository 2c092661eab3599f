// The MCAP reader on arbitrary bytes, through the in-memory open: it must never crash, leak or
// allocate without bound, every error must start with the offset it concerns, and a file without
// summary must count, when opened, the messages a full read then visits.
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>

#include "fuzz_check.hpp"
#include "plexus/mcap/reader.hpp"

namespace mcap = plexus::mcap;
namespace proto = plexus::proto;

namespace {

bool names_an_offset(const std::string& message) {
    return message.rfind("offset ", 0) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    auto reader = mcap::Reader::open_bytes(proto::Bytes(data, data + size));
    if (!reader) {
        PLEXUS_FUZZ_CHECK(names_an_offset(reader.error().message));
        return 0;
    }
    PLEXUS_FUZZ_CHECK(reader->file_size() == size);

    std::uint64_t visited = 0;
    std::uint64_t payload = 0;
    const auto all = reader->for_each_message([&](const mcap::MessageView& message) {
        ++visited;
        payload += message.data.size();
        return true;
    });
    if (!all) {
        PLEXUS_FUZZ_CHECK(names_an_offset(all.error().message));
    } else {
        PLEXUS_FUZZ_CHECK(payload <= size);
        if (!reader->has_summary())
            PLEXUS_FUZZ_CHECK(visited == reader->statistics().message_count);
    }

    // A channel filter (which may skip chunks by their index) and an early stop.
    if (!reader->channels().empty()) {
        const std::set<std::uint16_t> first{reader->channels().begin()->first};
        std::uint64_t filtered = 0;
        const auto some = reader->for_each_message(
            [&](const mcap::MessageView& message) {
                PLEXUS_FUZZ_CHECK(first.count(message.channel_id) == 1);
                ++filtered;
                return true;
            },
            &first);
        if (!some)
            PLEXUS_FUZZ_CHECK(names_an_offset(some.error().message));
        else if (all)
            PLEXUS_FUZZ_CHECK(filtered <= visited);
    }
    std::uint64_t before_stop = 0;
    (void)reader->for_each_message([&](const mcap::MessageView&) { return ++before_stop < 2; });
    PLEXUS_FUZZ_CHECK(before_stop <= 2);
    return 0;
}
