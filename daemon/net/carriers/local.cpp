// The local carrier (local.hpp).
#include "local.hpp"

namespace plexus::daemon::carriers {

proto::Result<SendingEnd> LocalCarrier::make_sending_end(const SendingContext& context) const {
    if (!context.inlet)
        return proto::Error{"carrier 'local' needs the destination's inlet"};  // a caller's bug
    SendingEnd end;
    end.sink = context.inlet;
    end.send_monitors = own_send_monitors(context, *context.inlet);
    return end;
}

}  // namespace plexus::daemon::carriers
