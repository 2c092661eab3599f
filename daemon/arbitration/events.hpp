#pragma once
// Threading: the daemon's one thread.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace plexus::daemon::arbitration {

/// Told of every change a monitor makes to an event container (a recording keeps them). Called
/// with the arbiter's lock held: it must only note the change (take a leaf lock at most), never
/// call back into the arbitration.
class EventObserver {
public:
    virtual ~EventObserver() = default;
    virtual void event_set(const std::string& name, const std::string& owner_label,
                           std::optional<double> lifetime, double now) = 0;
    virtual void event_unset(const std::string& name, const std::string& owner_label) = 0;
};

/// The event container of one input port, shared by the monitors of every connection into it.
/// Each monitor owns its own entries: an event exists while any live entry of that name exists,
/// so one monitor's unsetEvent or expiry never hides another's. Lifetimes are checked against
/// the time the caller passes, so a test's clock drives them.
class EventContainer {
public:
    struct Entry {
        std::string name;
        std::uint64_t owner = 0;        ///< the monitor's id
        std::string owner_label;        ///< for people: "/face/out (certainty)"
        std::optional<double> expires;  ///< absolute time; none = until unset
    };

    /// Sets (or refreshes) the owner's entry `name`; lifetime <= 0 or none = no expiry.
    void set(const std::string& name, std::uint64_t owner, const std::string& owner_label,
             std::optional<double> lifetime, double now);
    /// Removes the owner's own entry `name`, if any; others' entries stay.
    void unset(const std::string& name, std::uint64_t owner);
    /// Whether a live entry of `name` exists at `now`.
    bool has(const std::string& name, double now) const;
    /// Removes every entry of `owner` (its monitor went away).
    void remove_owner(std::uint64_t owner);
    /// The live entries at `now`, in the order they were set; expired ones are forgotten.
    const std::vector<Entry>& entries(double now);
    /// Who is told of changes; null (the default) costs one test per change.
    void set_observer(EventObserver* observer) { observer_ = observer; }

private:
    void forget_expired(double now);
    std::vector<Entry> entries_;  ///< few: a handful of monitors, each with a few events
    EventObserver* observer_ = nullptr;
};

}  // namespace plexus::daemon::arbitration
