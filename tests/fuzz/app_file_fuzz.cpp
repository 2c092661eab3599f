// The application-file parser (tools/app/app_parser.cpp) and the checks of `plexus check` that
// need no running system (duplicates, carriers, arbitration) on arbitrary text. Variables resolve
// from a fixed table, never the fuzzer's environment, so a crash reproduces anywhere.
// Properties: a file that cannot be read as an application says why; every problem names the
// file; what parsed keeps the fields the checks rely on.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "app_checks.hpp"
#include "app_file.hpp"
#include "fuzz_check.hpp"

namespace app = plexus::app;

namespace {

std::optional<std::string> variable(const std::string& name) {
    static const std::map<std::string, std::string> table{
        {"RATE", "50"}, {"NODE", "n1"}, {"EMPTY", ""}, {"CARRIER", "tcp+recv.priority"}};
    const auto it = table.find(name);
    if (it == table.end())
        return std::nullopt;
    return it->second;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    const std::string path = "/nonexistent/fuzz/app.json";
    const auto loaded = app::parse_app(text, path, variable);
    for (const auto& problem : loaded.problems)
        PLEXUS_FUZZ_CHECK(problem.rfind(path, 0) == 0);
    if (!loaded.app) {
        PLEXUS_FUZZ_CHECK(!loaded.problems.empty());
        return 0;
    }
    const auto& parsed = *loaded.app;
    for (std::size_t i = 0; i < parsed.components.size(); ++i)
        (void)parsed.components[i].label();
    for (const auto& connection : parsed.connections)
        (void)connection.label();
    // check_commands is left out: it looks in PATH, which would make runs depend on the machine.
    app::CheckReport report;
    app::check_duplicates(parsed, report);
    const auto carriers = app::check_carriers(parsed, report);
    // Keyed by each connection's position in the file (entries that were not whole are left out).
    for (const auto& entry : carriers) {
        const std::size_t index = entry.first;  // clang 14 cannot capture a structured binding
        PLEXUS_FUZZ_CHECK(std::any_of(parsed.connections.begin(), parsed.connections.end(),
                                      [&](const app::AppConnection& c) { return c.index == index; }));
    }
    app::check_arbitration(parsed, carriers, report);
    return 0;
}
