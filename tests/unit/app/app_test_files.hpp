#pragma once
// A temporary directory holding an application file (and its scripts), and the variables a test
// gives it instead of the process environment.

#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "app_checks.hpp"
#include "app_file.hpp"

namespace plexus::app::test {

class AppDir {
public:
    AppDir() {
        std::string pattern = (std::filesystem::temp_directory_path() / "plexus-app-XXXXXX").string();
        path_ = ::mkdtemp(pattern.data());
        std::filesystem::create_directories(path_ + "/monitors");
    }
    ~AppDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    AppDir(const AppDir&) = delete;
    AppDir& operator=(const AppDir&) = delete;

    /// Writes `text` into the directory as `name`; returns its path.
    std::string write(const std::string& name, const std::string& text) const {
        std::ofstream(path_ + "/" + name) << text;
        return path_ + "/" + name;
    }
    const std::string& path() const { return path_; }

private:
    std::string path_;
};

inline VariableLookup variables(std::map<std::string, std::string> values) {
    return [values = std::move(values)](const std::string& name) -> std::optional<std::string> {
        auto it = values.find(name);
        if (it == values.end())
            return std::nullopt;
        return it->second;
    };
}

/// Problems of loading and checking the file: what `plexus check` prints.
inline std::vector<std::string> problems_of(const std::string& path,
                                            const VariableLookup& vars = variables({})) {
    auto loaded = load_app(path, vars);
    auto problems = loaded.problems;
    if (loaded.app) {
        auto report = check_app(*loaded.app);
        problems.insert(problems.end(), report.problems.begin(), report.problems.end());
    }
    return problems;
}

}  // namespace plexus::app::test
