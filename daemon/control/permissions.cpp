// The control plane's checks of the permissions file (core/permissions.hpp): made when a port is
// opened, a connection made or a link attached, never per message.
#include "control_plane.hpp"
#include "net/session.hpp"

namespace plexus::daemon {

proto::Status ControlPlane::permitted(const Principal& who, Action action, std::string_view port) {
    auto allowed = permissions_.check(who, action, port);
    if (!allowed)
        ++host_.counters().permission_refusals;
    return allowed;
}

proto::Status ControlPlane::permitted(const Session* asker, Action action, std::string_view port) {
    if (!asker || !permissions_.enforcing())
        return proto::Ok{};
    return permitted(asker->principal(), action, port);
}

proto::Status ControlPlane::connect_permitted(const Session* asker, const proto::Carrier& carrier,
                                              const std::string& source, const std::string& destination,
                                              bool local_destination) {
    if (!asker || !permissions_.enforcing())
        return proto::Ok{};
    if (auto allowed = permitted(asker, Action::connect, source); !allowed)
        return allowed;
    for (const auto& clause : carrier.clauses) {
        if (clause.side == proto::Side::send) {
            if (auto allowed = permitted(asker, Action::monitor, source); !allowed)
                return allowed;
        } else if (local_destination) {  // a remote destination's daemon checks its own, at attach
            if (auto allowed = permitted(asker, Action::monitor, destination); !allowed)
                return allowed;
        }
    }
    if (local_destination)
        return permitted(asker, Action::write, destination);
    return proto::Ok{};
}

}  // namespace plexus::daemon
