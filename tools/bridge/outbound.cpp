#include "outbound.hpp"

namespace plexus::bridge {

namespace {
PortOptions options_with(std::size_t capacity) {
    PortOptions options;
    options.capacity = capacity;
    return options;
}
}  // namespace

Outbound::Outbound(Client& client, const std::string& port, std::string peer, std::set<std::string> own_ports,
                   std::size_t capacity)
    : port_(client.open(port, options_with(capacity))),
      counters_(port, std::move(peer)),
      own_ports_(std::move(own_ports)) {}

void Outbound::start(Send send) {
    subscription_ = std::make_unique<Subscription>(port_, [this,
                                                           send = std::move(send)](const Received& message) {
        if (own_ports_.contains(message.envelope.source)) {
            counters_.dropped("own_message", "it came from " + message.envelope.source +
                                                 ", which this bridge writes: sending it back would loop");
            return;
        }
        try {
            send(message, counters_);
        } catch (const std::exception& error) {
            counters_.dropped("not_delivered", error.what());
        }
    });
}

void Outbound::stop() {
    subscription_.reset();
}

PortOptions inbound_port_options() {
    return PortOptions{};
}

}  // namespace plexus::bridge
