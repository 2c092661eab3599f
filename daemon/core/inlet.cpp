#include "inlet.hpp"

#include "../monitor/chain.hpp"

namespace plexus::daemon {

void Inlet::deliver(const Message& message) {
    ++received;
    if (!chain) {
        ++delivered;
        port_->deliver(message);
        return;
    }
    Message passed = message;
    if (!chain->process(passed)) {
        ++dropped_by_monitor;
        return;
    }
    ++delivered;
    port_->deliver(passed);
}

}  // namespace plexus::daemon
