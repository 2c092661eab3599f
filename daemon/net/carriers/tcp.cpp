// The tcp carrier (tcp.hpp).
#include "tcp.hpp"

#include <algorithm>

namespace plexus::daemon::carriers {

proto::Result<SendingEnd> TcpCarrier::make_sending_end(const SendingContext& context) const {
    // Messages wait in the link's queue and leave on its socket. Into a latest port the link keeps
    // only the newest few and a small socket buffer, so a slow network adds little delay (the
    // kernel's buffer would otherwise hold seconds of data at 10 Mbit/s); into a strict port it
    // holds the writer back.
    const NetConfig& config = context.host.config();
    const bool latest = context.attached.policy == "latest";
    const std::size_t capacity =
        latest ? std::min<std::size_t>(config.link_capacity,
                                       std::max<std::uint64_t>(1, context.attached.capacity))
               : config.link_capacity;
    constexpr int latest_send_buffer = 64 * 1024;
    if (latest)
        context.link->limit_send_buffer(latest_send_buffer);
    auto link = std::make_shared<TcpLink>(context.link, capacity, config.queue_bytes,
                                          latest ? QueuePolicy::latest : QueuePolicy::strict);
    SendingEnd end;
    end.sink = link;
    end.send_monitors = own_send_monitors(context, *link);
    end.queue = link->queue();
    return end;
}

}  // namespace plexus::daemon::carriers
