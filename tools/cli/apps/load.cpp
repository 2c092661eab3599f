#include "load.hpp"

#include <iostream>

#include "app_checks.hpp"

namespace plexus::cli {

std::optional<app::App> load_checked_app(const std::string& file, bool full_check) {
    auto loaded = app::load_app(file, app::process_environment());
    auto problems = loaded.problems;
    if (loaded.app && full_check) {
        auto report = app::check_app(*loaded.app);
        problems.insert(problems.end(), report.problems.begin(), report.problems.end());
        for (const auto& warning : report.warnings)
            std::cerr << "warning: " << warning << '\n';
    }
    for (const auto& problem : problems)
        std::cerr << problem << '\n';
    if (!problems.empty()) {
        std::cerr << "plexus: " << file << ": " << problems.size()
                  << (problems.size() == 1 ? " problem" : " problems") << '\n';
        return std::nullopt;
    }
    return std::move(loaded.app);
}

}  // namespace plexus::cli
