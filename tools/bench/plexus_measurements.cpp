#include "plexus_measurements.hpp"
#include <cstring>

#include <mutex>
#include <stdexcept>
#include <thread>

#include "plexus/client.hpp"
#include "process_stats.hpp"

namespace plexus::bench {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

Value blob(std::size_t size) {
    return Value::binary(std::vector<std::uint8_t>(size, 0x5a));
}

}  // namespace

/// A detection-like map of about `size` CBOR bytes: {"c": 0.9, "pad": "xx..."}.
Value detection(std::size_t size) {
    constexpr std::size_t overhead = 20;  // map header, two keys, a double, the string's header
    return Value{{"c", 0.9}, {"pad", std::string(size > overhead ? size - overhead : 0, 'x')}};
}

void check_detection(const Received& message) {
    if (!message.data.is_object() || !message.data.contains("c"))
        throw std::runtime_error("a message arrived without its field c: " +
                                 message.data.dump().substr(0, 80));
}

void connect_when_registered(Client& client, const std::string& source, const std::string& destination,
                             const std::string& carrier) {
    const auto deadline = Clock::now() + stall_timeout;
    while (!client.lookup(source) || !client.lookup(destination)) {
        if (Clock::now() > deadline)
            throw std::runtime_error(source + " or " + destination + " never registered");
        std::this_thread::sleep_for(1ms);  // polling interval
    }
    client.connect(source, destination, carrier);
}

namespace {

void check_payload(const Received& message, std::size_t size) {
    if (!message.data.is_binary() || message.data.get_binary().size() != size) {
        throw std::runtime_error("plexus delivered a payload that is not the " + std::to_string(size) +
                                 "-byte blob written (from " + message.envelope.source + ")");
    }
}

}  // namespace

Client connect_client(const std::string& socket) {
    return Client(Client::Options{socket, 10000ms});
}

namespace {

PortOptions queue(const Options& options) {
    return {QueuePolicy::strict, options.capacity};
}

/// "udp-" for options.carrier "udp": keeps the ports of scenarios on different carriers apart.
std::string carrier_tag(const Options& options) {
    if (!options.port_tag.empty())
        return options.port_tag + "-";
    return options.carrier.empty() ? "" : options.carrier + "-";
}

bool lossy_carrier(const std::string& carrier) {
    return carrier.rfind("udp", 0) == 0 || carrier.rfind("mcast", 0) == 0;
}

// A lossy stream is over once nothing has arrived for this long (its last messages were lost).
constexpr auto lossy_idle_timeout = 500ms;

class PlexusLatency : public Measurement {
public:
    PlexusLatency(const Topology& topology, const Options& options)
        : pids_(topology.pids()),
          size_(options.size),
          count_(latency_count(options)),
          payload_(blob(options.size)),
          loans_(options.loans),
          near_(connect_client(topology.near_socket())),
          far_(connect_client(topology.far_socket())),
          ping_(near_.open("/bench/" + carrier_tag(options) + "ping", queue(options))),
          ping_in_(near_.open("/bench/" + carrier_tag(options) + "ping-in", queue(options))),
          pong_in_(far_.open("/bench/" + carrier_tag(options) + "pong-in", queue(options))),
          pong_(far_.open("/bench/" + carrier_tag(options) + "pong", queue(options))) {
        connect_when_registered(near_, ping_.name(), pong_in_.name(), options.carrier);
        connect_when_registered(near_, pong_.name(), ping_in_.name(), options.carrier);
        echo_ = std::jthread([this](const std::stop_token& stop) { echo(stop); });
    }

    ~PlexusLatency() override {
        echo_.request_stop();
        try {
            ping_.write(Value(nullptr), true);  // wakes the echo thread now rather than at its next timeout
        } catch (...) {
            // The echo thread also stops on its own within one read timeout.
        }
    }

    RunResult run() override {
        return time_round_trips(count_, size_, pids_, [this] { return round_trip(); });
    }

private:
    /// A message of size_ bytes from a loan, only its first bytes written (a header, say).
    void send_loan(Port& port) {
        Loan loan = port.loan(size_);
        std::memset(loan.bytes().data(), 0x5a, std::min<std::size_t>(64, size_));
        port.send_loan(std::move(loan));
    }

    double round_trip_with_loans() {
        const auto sent = Clock::now();
        send_loan(ping_);
        auto reply = ping_in_.read_view(stall_timeout);
        const auto back = Clock::now();
        if (!reply)
            throw std::runtime_error("plexus: no echo within 10 s");
        if (reply->bytes().size() != size_)
            throw std::runtime_error("plexus: the echo is not a blob of the size sent");
        return std::chrono::duration<double, std::micro>(back - sent).count() / 2;
    }

    /// One ping and its echo; returns half the round trip in microseconds.
    double round_trip() {
        if (loans_)
            return round_trip_with_loans();
        const auto sent = Clock::now();
        ping_.write(payload_, true);
        auto reply = ping_in_.read(stall_timeout);
        const auto back = Clock::now();
        if (!reply) {
            std::lock_guard lock(echo_error_mutex_);
            throw std::runtime_error("plexus: no echo within 10 s" +
                                     (echo_error_.empty() ? "" : ": " + echo_error_));
        }
        check_payload(*reply, size_);
        return std::chrono::duration<double, std::micro>(back - sent).count() / 2;
    }

    void echo(const std::stop_token& stop) {
        try {
            while (loans_ && !stop.stop_requested()) {
                auto view = pong_in_.read_view(100ms);
                if (!view)
                    continue;
                if (view->bytes().empty())
                    return;  // the destructor's null
                send_loan(pong_);
            }
            while (!stop.stop_requested()) {
                auto message = pong_in_.read(100ms);
                if (!message)
                    continue;
                if (message->data.is_null())
                    return;
                pong_.write(message->data, true);
            }
        } catch (const std::exception& e) {
            std::lock_guard lock(echo_error_mutex_);
            echo_error_ = e.what();
        }
    }

    std::vector<pid_t> pids_;
    std::size_t size_;
    std::size_t count_;
    Value payload_;
    bool loans_ = false;
    Client near_;
    Client far_;
    Port ping_;
    Port ping_in_;
    Port pong_in_;
    Port pong_;
    std::mutex echo_error_mutex_;
    std::string echo_error_;
    std::jthread echo_;  // last: joined before the ports and clients it uses are destroyed
};

/// Calls, one at a time: A's caller port, connected to a port B serves (Client::serve, on the
/// Service's thread, answering with the request's data), so that each request goes A -> daemon(s)
/// -> B and each answer B -> daemon(s) -> A: the hops of the ping-pong above, with the daemons
/// keeping each call's entry and routing its answer back.
class PlexusCalls : public Measurement {
public:
    PlexusCalls(const Topology& topology, const Options& options)
        : pids_(topology.pids()),
          size_(options.size),
          count_(latency_count(options)),
          payload_(blob(options.size)),
          caller_client_(connect_client(topology.near_socket())),
          server_client_(connect_client(topology.far_socket())),
          service_(server_client_.serve("/bench/" + carrier_tag(options) + "served",
                                        [](const Received& request) { return request.data; })),
          caller_(caller_client_.open("/bench/" + carrier_tag(options) + "caller", queue(options))) {
        connect_when_registered(caller_client_, caller_.name(), service_.port(), options.carrier);
    }

    RunResult run() override {
        return time_round_trips(count_, size_, pids_, [this] { return call(); });
    }

private:
    /// One call and its answer; returns the whole round trip in microseconds.
    double call() {
        const auto sent = Clock::now();
        const Received answer = caller_.request(payload_, stall_timeout);
        const auto back = Clock::now();
        check_payload(answer, size_);
        return std::chrono::duration<double, std::micro>(back - sent).count();
    }

    std::vector<pid_t> pids_;
    std::size_t size_;
    std::size_t count_;
    Value payload_;
    Client caller_client_;
    Client server_client_;
    Service service_;  // after its client: closed (and its thread joined) before the client goes
    Port caller_;
};

class PlexusThroughput : public Measurement {
public:
    PlexusThroughput(const Topology& topology, const Options& options, StreamSpec spec)
        : pids_(topology.pids()),
          size_(options.size),
          count_(throughput_count(options)),
          payload_(std::move(spec.payload)),
          check_(std::move(spec.check)),
          lossy_(spec.lossy),
          writer_(connect_client(topology.near_socket())),
          reader_(connect_client(topology.far_socket())),
          source_(writer_.open("/bench/" + spec.name + "source", queue(options))),
          sink_(reader_.open("/bench/" + spec.name + "sink", queue(options))) {
        connect_when_registered(writer_, source_.name(), sink_.name(), spec.carrier);
        if (spec.prepare)
            extra_ports_ = spec.prepare(writer_, sink_.name());
        stream(std::max<std::size_t>(count_ / 10, 10));  // warm-up: buffers grown, connections hot
    }

    RunResult run() override {
        const double cpu_before = cpu_seconds(pids_);
        const auto start = Clock::now();
        auto [latencies, last] = stream(count_);
        const double cpu = cpu_seconds(pids_) - cpu_before;
        const std::size_t arrived = latencies.size();
        if (arrived == 0)
            throw std::runtime_error("plexus: none of " + std::to_string(count_) + " messages arrived");
        auto result = summarize(latencies, arrived, size_, last - start, cpu);
        result.lost = static_cast<double>(count_ - arrived) / static_cast<double>(count_);
        return result;
    }

private:
    struct Streamed {
        std::vector<double> latencies_us;  ///< one per message that arrived
        Clock::time_point last;
    };

    /// Writes `count` messages from this thread while another thread reads them all.
    Streamed stream(std::size_t count) {
        Streamed streamed;
        streamed.latencies_us.reserve(count);
        std::string error;
        const std::uint64_t first = written_ + 1;  // the seq of this stream's first message
        written_ += count;
        std::jthread reader([&] {
            try {
                if (lossy_) {
                    read_lossy(first, count, streamed);
                    return;
                }
                for (std::size_t i = 0; i < count; ++i) {
                    auto message = sink_.read(stall_timeout);
                    if (!message)
                        throw std::runtime_error("plexus: message " + std::to_string(i) + " never arrived");
                    const std::uint64_t arrived = now_ns();
                    if (message->envelope.seq != next_seq_) {
                        throw std::runtime_error("plexus: expected seq " + std::to_string(next_seq_) +
                                                 ", got " + std::to_string(message->envelope.seq));
                    }
                    ++next_seq_;
                    check_(*message);
                    streamed.latencies_us.push_back(static_cast<double>(arrived - message->envelope.time_ns) /
                                                    1e3);
                }
                streamed.last = Clock::now();
            } catch (const std::exception& e) {
                error = e.what();
            }
        });
        for (std::size_t i = 0; i < count; ++i)
            source_.write(payload_, false);
        source_.flush();
        reader.join();
        if (!error.empty())
            throw std::runtime_error(error);
        return streamed;
    }

    /// Reads messages `first` to `first + count - 1` as they come, skipping lost ones (and late
    /// ones of an earlier stream), until the last one or a quiet lossy_idle_timeout.
    void read_lossy(std::uint64_t first, std::size_t count, Streamed& streamed) {
        const std::uint64_t end = first + count;
        streamed.last = Clock::now();
        // The first message may wait for the writer's start; then the stream must keep flowing.
        auto timeout = std::chrono::duration_cast<std::chrono::milliseconds>(stall_timeout);
        while (next_seq_ < end) {
            auto message = sink_.read(timeout);
            if (!message)
                break;
            const std::uint64_t arrived = now_ns();
            const std::uint64_t seq = message->envelope.seq;
            if (seq < std::max(first, next_seq_))
                continue;  // late: of an earlier stream, or out of order
            next_seq_ = seq + 1;
            if (seq >= end)
                throw std::runtime_error("plexus: seq " + std::to_string(seq) + " was never written");
            check_(*message);
            streamed.latencies_us.push_back(static_cast<double>(arrived - message->envelope.time_ns) / 1e3);
            streamed.last = Clock::now();
            timeout = lossy_idle_timeout;
        }
        next_seq_ = end;
    }

    std::vector<pid_t> pids_;
    std::size_t size_;
    std::size_t count_;
    Value payload_;
    std::function<void(const Received&)> check_;
    bool lossy_ = false;
    Client writer_;
    Client reader_;
    Port source_;
    Port sink_;
    std::vector<Port> extra_ports_;  ///< opened by spec.prepare; open for as long as the stream
    std::uint64_t next_seq_ = 1;
    std::uint64_t written_ = 0;  ///< messages written by all streams so far
};

}  // namespace

std::unique_ptr<Measurement> plexus_latency(const Topology& topology, const Options& options) {
    return std::make_unique<PlexusLatency>(topology, options);
}

std::unique_ptr<Measurement> plexus_calls(const Topology& topology, const Options& options) {
    return std::make_unique<PlexusCalls>(topology, options);
}

std::unique_ptr<Measurement> plexus_throughput(const Topology& topology, const Options& options) {
    const std::size_t size = options.size;
    StreamSpec spec{carrier_tag(options),
                    blob(size),
                    options.carrier,
                    [size](const Received& message) { check_payload(message, size); },
                    {},
                    lossy_carrier(options.carrier)};
    return std::make_unique<PlexusThroughput>(topology, options, std::move(spec));
}

std::unique_ptr<Measurement> plexus_stream(const Topology& topology, const Options& options,
                                           StreamSpec spec) {
    return std::make_unique<PlexusThroughput>(topology, options, std::move(spec));
}

}  // namespace plexus::bench
