// Plexus as one of the systems of `plexus-bench peers`: one plexusd with its embedded name server,
// reached by every client over its Unix socket, as a component on the same machine would. A topic
// is a set of ports: each publisher opens /peers/TOPIC/pubN, each subscriber /peers/TOPIC/subN
// (strict queue, the daemon's default length), and the broker connects every publisher of a
// topic to every subscriber of it, as the other systems do by subscription.
//
// `plexus-loans` is the same broker used as iceoryx is: a publisher writes each message in place in
// its port's shared memory (Port::loan, send_loan), a subscriber reads the stamp where the message
// lies (Port::read_view) and copies nothing, and the ping-pong's echo answers with a loan of the
// same size holding only the stamp, as iceoryx's far echo does. Every message still passes through
// plexusd (the daemon passes the place on; it does not touch the payload).
#include <atomic>
#include <cstring>
#include <map>
#include <optional>
#include <thread>

#include "../plexus_measurements.hpp"
#include "../topology.hpp"
#include "plexus/client.hpp"
#include "pubsub.hpp"

namespace plexus::bench::peers {

namespace {

/// How a system's clients move bytes: copied by write()/read(), or lent in shared memory.
enum class Bytes { copied, lent };

class PlexusPublisher : public Publisher {
public:
    PlexusPublisher(const std::string& socket, const std::string& port, Traffic traffic, Bytes bytes)
        : client_(connect_client(socket)),
          port_(client_.open(port)),
          buffered_(traffic == Traffic::bulk),
          lends_(bytes == Bytes::lent) {}

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

    std::span<char> loan(std::size_t size) override {
        if (!lends_)
            return {};
        loan_.emplace(port_.loan(size));
        const auto bytes = loan_->bytes();
        return {reinterpret_cast<char*>(bytes.data()), bytes.size()};
    }
    void publish_loan() override {
        port_.send_loan(std::move(*loan_), !buffered_);
        loan_.reset();
    }

private:
    Client client_;
    Port port_;
    bool buffered_;
    bool lends_;
    std::optional<Loan> loan_;  ///< the last loan(), until publish_loan()
};

/// Reads the stamp at the start of a message's bytes; kind 0 when it is too short.
Stamp stamp_in(std::span<const std::uint8_t> bytes) {
    Stamp stamp{};
    stamp.kind = Kind{0};
    if (bytes.size() >= sizeof stamp)
        std::memcpy(&stamp, bytes.data(), sizeof stamp);
    return stamp;
}

class PlexusSubscriber : public Subscriber {
public:
    PlexusSubscriber(const std::string& socket, const std::string& port, Bytes bytes)
        : client_(connect_client(socket)), port_(client_.open(port)), views_(bytes == Bytes::lent) {}

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        const auto message = port_.read(timeout);
        if (!message)
            return false;
        const auto& bytes = message->data.get_binary();
        payload.assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
        return true;
    }

    bool receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) override {
        if (!views_)
            return Subscriber::receive_stamp(arrival, timeout);
        const auto view = port_.read_view(timeout);
        if (!view)
            return false;
        arrival.arrived_ns = steady_ns();
        arrival.stamp = stamp_in(view->bytes());
        return true;
    }

private:
    Client client_;
    Port port_;
    bool views_;  ///< receive_stamp() reads in place (read_view) instead of copying (read)
};

/// The ping-pong's echo for lent bytes: views each ping where it lies and answers with a loan of
/// the same size holding only its stamp, on a thread of its own, until destroyed.
class PlexusLoanEcho : public Echo {
public:
    PlexusLoanEcho(const std::string& socket, const std::string& from, const std::string& to)
        : in_client_(connect_client(socket)),
          out_client_(connect_client(socket)),
          in_(in_client_.open(from)),
          out_(out_client_.open(to)),
          thread_([this] { run(); }) {}
    ~PlexusLoanEcho() override {
        stop_ = true;
        thread_.join();
    }
    PlexusLoanEcho(const PlexusLoanEcho&) = delete;
    PlexusLoanEcho& operator=(const PlexusLoanEcho&) = delete;
    const std::string& in_name() const { return in_.name(); }
    const std::string& out_name() const { return out_.name(); }

private:
    void run() {
        using namespace std::chrono_literals;
        while (!stop_) {
            auto view = in_.read_view(100ms);
            if (!view)
                continue;
            const std::size_t size = view->bytes().size();
            const Stamp stamp = stamp_in(view->bytes());
            // Let go of the ping before answering: its release then travels with the answer's frame
            // instead of in a frame of its own (which would wake the daemon once more).
            view.reset();
            Loan answer = out_.loan(size);
            std::memcpy(answer.bytes().data(), &stamp, std::min(size, sizeof stamp));
            out_.send_loan(std::move(answer));
        }
    }

    Client in_client_;
    Client out_client_;
    Port in_;
    Port out_;
    std::atomic<bool> stop_{false};
    std::thread thread_;  // last: starts after the ports exist
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
    PlexusBroker(const BrokerSetup& setup, Bytes bytes)
        : topology_(Topology::plexus(setup.dir, setup.plexusd, 1)),
          control_(connect_client(topology_->near_socket())),
          bytes_(bytes) {}

    std::vector<pid_t> pids() const override { return topology_->pids(); }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic traffic) override {
        const std::string name = port_name(topic, "pub");
        auto publisher = std::make_unique<PlexusPublisher>(topology_->near_socket(), name, traffic, bytes_);
        auto& ports = topics_[topic];
        join(name, ports.publishers, ports.subscribers, true);
        return publisher;
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        const std::string name = port_name(topic, "sub");
        auto subscriber = std::make_unique<PlexusSubscriber>(topology_->near_socket(), name, bytes_);
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

    /// Lent bytes echo with loans; copied bytes leave the echo to the scenario (receive, publish).
    std::unique_ptr<Echo> far_echo(const std::string& from, const std::string& to) override {
        if (bytes_ != Bytes::lent)
            return nullptr;
        auto echo = std::make_unique<PlexusLoanEcho>(topology_->near_socket(), port_name(from, "sub"),
                                                     port_name(to, "pub"));
        auto& in_topic = topics_[from];
        join(echo->in_name(), in_topic.subscribers, in_topic.publishers, false);
        auto& out_topic = topics_[to];
        join(echo->out_name(), out_topic.publishers, out_topic.subscribers, true);
        return echo;
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
    Bytes bytes_;
    std::map<std::string, TopicPorts> topics_;
    int opened_ = 0;
};

}  // namespace

System plexus_system() {
    return {"plexus",
            [](const BrokerSetup& setup) { return std::make_unique<PlexusBroker>(setup, Bytes::copied); }};
}

System plexus_loans_system() {
    return {"plexus-loans",
            [](const BrokerSetup& setup) { return std::make_unique<PlexusBroker>(setup, Bytes::lent); }};
}

}  // namespace plexus::bench::peers
