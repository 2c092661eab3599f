#pragma once
// Threading: the daemon's one thread.

#include "carrier.hpp"

namespace plexus::daemon::carriers {

/// local: both ports on this daemon, no link and no copy. The connection's sink is the
/// destination's inlet itself, so a message written into the source reaches the destination's
/// monitors and arbitration within the same call. Chosen when the connect names no carrier and
/// both ports are here.
class LocalCarrier final : public Carrier {
public:
    std::string_view name() const override { return "local"; }
    bool within_daemon() const override { return true; }
    proto::Result<SendingEnd> make_sending_end(const SendingContext& context) const override;
};

}  // namespace plexus::daemon::carriers
