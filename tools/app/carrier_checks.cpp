// Carriers of an application's connections: the grammar and what this build supports (proto's
// parser, as `connect` uses it), the arbitration keys (the daemon's carrier_rules), and the
// scripts they name. Done before anything starts, so `up` never stops halfway on a typo.
#include <filesystem>

#include "app_checks.hpp"
#include "arbitration/carrier_rules.hpp"
#include "arbitration/clock.hpp"

namespace plexus::app {

namespace arbitration = daemon::arbitration;

namespace {

/// The daemon's script-name rule (monitor/script_library.cpp): relative, no `..`.
std::optional<std::string> script_name_error(const std::string& name) {
    if (name.empty())
        return "empty script name (file.NAME)";
    if (name.front() == '/' || name.find('\\') != std::string::npos)
        return "script name '" + name + "' must be relative to a scripts directory";
    for (const auto& part : std::filesystem::path(name)) {
        if (part == "..")
            return "script name '" + name + "' must not contain '..'";
    }
    return std::nullopt;
}

/// Problems with the scripts of one carrier's portmonitor clauses.
void check_scripts(const App& app, const AppConnection& connection, const proto::Carrier& carrier,
                   CheckReport& report) {
    const std::string where = app.file + ": " + connection.label() + ": \"carrier\": ";
    for (const auto& clause : carrier.clauses) {
        if (clause.modifier != "portmonitor" || arbitration::arbitration_only(clause))
            continue;
        const auto* type = clause.find("type");
        const std::string type_name = type ? type->value.value_or("") : "lua";
        if (type_name != "lua" && type_name != "so") {
            report.problems.push_back(where + "portmonitor type '" + type_name +
                                      "' is not supported (type.lua or type.so)");
            continue;
        }
        const auto* file = clause.find("file");
        if (!file || !file->value || file->value->empty()) {
            report.problems.push_back(where + "portmonitor clause without file.NAME");
            continue;
        }
        const std::string& name = *file->value;
        if (auto error = script_name_error(name)) {
            report.problems.push_back(where + *error);
            continue;
        }
        if (type_name == "so")
            continue;  // a compiled monitor is found in the daemon's --monitor-libs, which the file does not
                       // name
        const bool has_extension = name.size() > 4 && name.compare(name.size() - 4, 4, ".lua") == 0;
        const std::string file_name = has_extension ? name : name + ".lua";
        bool found = false;
        for (const auto& dir : app.scripts) {
            std::error_code ec;
            found = found || std::filesystem::is_regular_file(std::filesystem::path(dir) / file_name, ec);
        }
        if (!found) {
            std::string dirs;
            for (const auto& dir : app.scripts)
                dirs += (dirs.empty() ? "" : ", ") + dir;
            report.problems.push_back(
                where + "script file." + name + ": no " + file_name +
                " in the file's \"scripts\" directories (" +
                (dirs.empty() ? "none given: add \"scripts\": [\"DIR\"], relative to the file" : dirs) + ")");
        }
    }
}

}  // namespace

std::map<std::size_t, proto::Carrier> check_carriers(const App& app, CheckReport& report) {
    for (const auto& dir : app.scripts) {
        std::error_code ec;
        if (!std::filesystem::is_directory(dir, ec))
            report.problems.push_back(app.file + ": \"scripts\": " + dir + " is not a directory");
    }
    std::map<std::size_t, proto::Carrier> good;
    for (const auto& connection : app.connections) {
        if (connection.carrier.empty()) {
            good[connection.index] = proto::Carrier{};  // the daemon chooses local or tcp
            continue;
        }
        const std::string where = app.file + ": " + connection.label() + ": \"carrier\": ";
        auto parsed = proto::parse_carrier(connection.carrier);
        if (!parsed) {
            report.problems.push_back(where + parsed.error().message);
            continue;
        }
        if (auto valid = proto::validate_carrier(*parsed); !valid) {
            report.problems.push_back(where + valid.error().message);
            continue;
        }
        // The arbitration keys as the daemon reads them: a constraint that does not parse, a
        // priority key that is not a number, arbitration on the send side.
        arbitration::ManualClock clock;
        auto arbiter = std::make_shared<arbitration::Arbiter>(clock);
        arbitration::Member member(arbiter, connection.source);
        if (auto configured = arbitration::configure_member(member, *parsed); !configured) {
            report.problems.push_back(where + configured.error().message);
            continue;
        }
        check_scripts(app, connection, *parsed, report);
        good[connection.index] = std::move(*parsed);
    }
    return good;
}

}  // namespace plexus::app
