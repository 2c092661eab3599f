#pragma once
// Threading: one thread (the daemon's control thread, or the name server's).

#include <memory>
#include <set>
#include <string>

#include "core/permissions.hpp"

namespace plexus::daemon {

/// The daemon's or name server's check of permissions (core/permissions.hpp): everything is
/// allowed without a permissions file; with one, what no rule allows is refused, each refusal
/// counted and logged the first time for its who, what and where (a peer that retries in a loop
/// does not flood the log; the count still says how often).
class PermissionGate {
public:
    explicit PermissionGate(std::shared_ptr<const Permissions> permissions = nullptr)
        : permissions_(std::move(permissions)) {}

    bool enforcing() const { return permissions_ != nullptr; }
    /// Ok, or the Error to give the asker: "node 'x' may not write /arm/cmd (permissions FILE)".
    /// `log_prefix` starts the log line ("names: " for the name server).
    proto::Status check(const Principal& who, Action action, std::string_view port,
                        std::string_view log_prefix = {});
    std::uint64_t refusals() const { return refusals_; }
    /// Reads the permissions file again (SIGHUP): its new rules apply to every check from now on,
    /// and a refusal is logged once again under them. An Error (the file is unreadable or wrong, or
    /// none was given at start) keeps the rules in force.
    proto::Status reload();
    /// "FILE: N rules" for the log; "" without a file.
    std::string summary() const;

private:
    std::shared_ptr<const Permissions> permissions_;
    std::uint64_t refusals_ = 0;
    std::set<std::string> logged_;  ///< refusals logged once each, up to a bound
};

}  // namespace plexus::daemon
