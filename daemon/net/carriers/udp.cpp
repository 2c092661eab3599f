// The udp carrier (udp.hpp).
#include "udp.hpp"

#include <nlohmann/json.hpp>

#include "../../core/batch.hpp"

namespace plexus::daemon::carriers {

void UdpLink::deliver(const Message& message) {
    for_each_record(message, [this](const Message& single) {
        socket_.send_counted(to_, stream_, next_message_, single.record, counters_, description_,
                             marks_ ? &*marks_ : nullptr);
    });
}

void UdpLink::report_stats(nlohmann::json& entry) const {
    entry["udp"] = {{"messages", counters_.messages},
                    {"datagrams", counters_.datagrams},
                    {"dropped_too_large", counters_.dropped_too_large},
                    {"dropped_send", counters_.dropped_send}};
}

}  // namespace plexus::daemon::carriers
