#include "events.hpp"

#include <algorithm>

namespace plexus::daemon::arbitration {

namespace {
bool live(const EventContainer::Entry& entry, double now) {
    return !entry.expires || now < *entry.expires;
}
}  // namespace

void EventContainer::set(const std::string& name, std::uint64_t owner, const std::string& owner_label,
                         std::optional<double> lifetime, double now) {
    std::optional<double> expires;
    if (lifetime && *lifetime > 0)
        expires = now + *lifetime;
    if (observer_)
        observer_->event_set(name, owner_label, lifetime, now);
    for (auto& entry : entries_) {
        if (entry.owner == owner && entry.name == name) {
            entry.expires = expires;
            return;
        }
    }
    forget_expired(now);  // keeps the list short when scripts set events with lifetimes forever
    entries_.push_back({name, owner, owner_label, expires});
}

void EventContainer::unset(const std::string& name, std::uint64_t owner) {
    std::erase_if(entries_, [&](const Entry& entry) {
        if (entry.owner != owner || entry.name != name)
            return false;
        if (observer_)
            observer_->event_unset(entry.name, entry.owner_label);
        return true;
    });
}

bool EventContainer::has(const std::string& name, double now) const {
    return std::any_of(entries_.begin(), entries_.end(),
                       [&](const Entry& entry) { return entry.name == name && live(entry, now); });
}

void EventContainer::remove_owner(std::uint64_t owner) {
    std::erase_if(entries_, [&](const Entry& entry) {
        if (entry.owner != owner)
            return false;
        if (observer_)
            observer_->event_unset(entry.name, entry.owner_label);
        return true;
    });
}

const std::vector<EventContainer::Entry>& EventContainer::entries(double now) {
    forget_expired(now);
    return entries_;
}

void EventContainer::forget_expired(double now) {
    std::erase_if(entries_, [&](const Entry& entry) { return !live(entry, now); });
}

}  // namespace plexus::daemon::arbitration
