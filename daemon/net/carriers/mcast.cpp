// The mcast carrier (mcast.hpp).
#include "mcast.hpp"

#include <nlohmann/json.hpp>

namespace plexus::daemon::carriers {

void McastLink::report_stats(nlohmann::json& entry) const {
    const auto& sent = sender_->counters();
    const auto& group = sender_->group();
    entry["mcast"] = {{"group", group.address().to_string() + ":" + std::to_string(group.port())},
                      {"messages_sent_once", sent.messages},
                      {"datagrams", sent.datagrams},
                      {"dropped_too_large", sent.dropped_too_large},
                      {"dropped_send", sent.dropped_send},
                      {"dropped_by_monitor", sent.dropped_by_monitor}};
}

}  // namespace plexus::daemon::carriers
