// plexusd's config file (daemon/app/config_file.hpp) on arbitrary text. It either applies or throws a
// std::exception with a reason, which plexusd turns into a message and an exit code; nothing else
// (no other exception, no undefined behaviour on out-of-range numbers). Property: a config it
// accepts keeps the bounds it checks, so a daemon never starts outside them.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>

#include <spdlog/spdlog.h>

#include "app/config_file.hpp"
#include "fuzz_check.hpp"
#include "plexus/proto/datagram.hpp"

namespace daemon_ = plexus::daemon;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    daemon_::DaemonConfig config;
    try {
        daemon_::apply_config_text("fuzz.json", text, config);
    } catch (const std::exception& e) {
        PLEXUS_FUZZ_CHECK(std::string(e.what()).size() > 0);
        return 0;
    }
    const auto& udp = config.udp;
    PLEXUS_FUZZ_CHECK(udp.fragment_bytes >= 256 && udp.fragment_bytes <= 65000);
    PLEXUS_FUZZ_CHECK(udp.max_message >= 1 && udp.max_message <= config.max_frame);
    PLEXUS_FUZZ_CHECK(plexus::proto::fragment_count(udp.max_message, udp.fragment_bytes) <=
                      plexus::proto::max_datagram_fragments);
    PLEXUS_FUZZ_CHECK(udp.reassembly_bytes >= udp.max_message);
    PLEXUS_FUZZ_CHECK(config.shm_region_bytes == 0 || config.shm_region_bytes >= 1024 * 1024);
    PLEXUS_FUZZ_CHECK(config.monitors.limits.memory_bytes >= 256 * 1024);
    PLEXUS_FUZZ_CHECK(config.monitors.limits.budget.count() >= 1 && config.monitors.quarantine_after >= 1);
    PLEXUS_FUZZ_CHECK(config.handshake_timeout.count() >= 100 &&
                      config.handshake_timeout.count() <= 3'600'000);
    // "log_level" sets spdlog's global level; put it back so the fuzzer's own runs stay quiet.
    spdlog::set_level(spdlog::level::off);
    return 0;
}
