// Plexus as one of the systems of `plexus-bench peers`: one plexusd with its embedded name server,
// reached by every client over its Unix socket, as a component on the same machine would. A topic
// is a set of ports: each publisher opens /peers/TOPIC/pubN, each subscriber /peers/TOPIC/subN
// (strict queue, the daemon's default length), and the broker connects every publisher of a
// topic to every subscriber of it, as the other systems do by subscription.
#include <map>

#include "../plexus_measurements.hpp"
#include "../topology.hpp"
#include "plexus/client.hpp"
#include "pubsub.hpp"

namespace plexus::bench::peers {

namespace {

class PlexusPublisher : public Publisher {
public:
    PlexusPublisher(const std::string& socket, const std::string& port, Traffic traffic)
        : client_(connect_client(socket)), port_(client_.open(port)), buffered_(traffic == Traffic::bulk) {}

    // Bulk traffic uses libplexus's documented buffered mode, write(v, false) then flush(), as the
    // NATS driver uses its flusher thread and the Redis driver pipelines; latency traffic flushes
    // every message.
    void publish(std::string_view payload) override {
        // Copied through pointers of one element type, i.e. with memcpy, as the other drivers copy
        // (a char-to-uint8_t iterator copy is an element loop: it made 1 MiB messages look slow).
        const auto* first = reinterpret_cast<const std::uint8_t*>(payload.data());
        port_.write(Value::binary(std::vector<std::uint8_t>(first, first + payload.size())), !buffered_);
    }
    void sync() override { port_.flush(); }

private:
    Client client_;
    Port port_;
    bool buffered_;
};

class PlexusSubscriber : public Subscriber {
public:
    PlexusSubscriber(const std::string& socket, const std::string& port)
        : client_(connect_client(socket)), port_(client_.open(port)) {}

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        const auto message = port_.read(timeout);
        if (!message)
            return false;
        const auto& bytes = message->data.get_binary();
        payload.assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
        return true;
    }

private:
    Client client_;
    Port port_;
};

/// A served port that answers each call with the request itself.
class PlexusResponder : public Responder {
public:
    PlexusResponder(const std::string& socket, const std::string& port)
        : client_(connect_client(socket)),
          service_(client_.serve(port, [](const Received& request) { return request.data; })) {}

private:
    Client client_;
    Service service_;
};

/// A caller port connected to the served port: each request is one call.
class PlexusRequester : public Requester {
public:
    PlexusRequester(Client& control, const std::string& socket, const std::string& port,
                    const std::string& service)
        : client_(connect_client(socket)), port_(client_.open(port)) {
        connect_when_registered(control, port, service);
    }

    bool request(std::string_view payload, std::string& answer, std::chrono::milliseconds timeout) override {
        try {
            const Received reply = port_.request(
                Value::binary(std::vector<std::uint8_t>(payload.begin(), payload.end())), timeout);
            const auto& bytes = reply.data.get_binary();
            answer.assign(bytes.begin(), bytes.end());
            return true;
        } catch (const Error& e) {
            if (e.code() == ErrorCode::timeout)
                return false;
            throw;
        }
    }

private:
    Client client_;
    Port port_;
};

class PlexusBroker : public Broker {
public:
    explicit PlexusBroker(const BrokerSetup& setup)
        : topology_(Topology::plexus(setup.dir, setup.plexusd, 1)),
          control_(connect_client(topology_->near_socket())) {}

    std::vector<pid_t> pids() const override { return topology_->pids(); }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic traffic) override {
        const std::string name = port_name(topic, "pub");
        auto publisher = std::make_unique<PlexusPublisher>(topology_->near_socket(), name, traffic);
        auto& ports = topics_[topic];
        join(name, ports.publishers, ports.subscribers, true);
        return publisher;
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        const std::string name = port_name(topic, "sub");
        auto subscriber = std::make_unique<PlexusSubscriber>(topology_->near_socket(), name);
        auto& ports = topics_[topic];
        join(name, ports.subscribers, ports.publishers, false);
        return subscriber;
    }

    std::unique_ptr<Responder> responder(const std::string& service) override {
        return std::make_unique<PlexusResponder>(topology_->near_socket(), "/peers/" + service);
    }

    std::unique_ptr<Requester> requester(const std::string& service) override {
        return std::make_unique<PlexusRequester>(control_, topology_->near_socket(),
                                                 port_name(service, "caller"), "/peers/" + service);
    }

private:
    struct TopicPorts {
        std::vector<std::string> publishers;
        std::vector<std::string> subscribers;
    };

    /// Connects a new port to every port on the other side of its topic, then lists it on its own.
    void join(const std::string& name, std::vector<std::string>& own_side,
              const std::vector<std::string>& other_side, bool is_publisher) {
        for (const auto& other : other_side) {
            if (is_publisher)
                connect_when_registered(control_, name, other);
            else
                connect_when_registered(control_, other, name);
        }
        own_side.push_back(name);
    }

    std::string port_name(const std::string& topic, const std::string& role) {
        return "/peers/" + topic + "/" + role + std::to_string(++opened_);
    }

    std::unique_ptr<Topology> topology_;
    Client control_;  ///< makes the connections
    std::map<std::string, TopicPorts> topics_;
    int opened_ = 0;
};

}  // namespace

System plexus_system() {
    return {"plexus", [](const BrokerSetup& setup) { return std::make_unique<PlexusBroker>(setup); }};
}

}  // namespace plexus::bench::peers
