#include "peer_scenarios.hpp"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <exception>
#include <functional>
#include <stdexcept>
#include <thread>

#include "../measurement.hpp"
#include "../process_stats.hpp"
#include "stamp.hpp"

namespace plexus::bench::peers {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr auto receive_slice = 100ms;       ///< how often a waiting subscriber looks at the clock
constexpr auto straggler_wait = 1s;         ///< quiet time after the publisher is done: the rest is lost
constexpr auto warm_up_deadline = 15s;      ///< until a first message must have got through
constexpr auto ping_pong_answer_wait = 5s;  ///< an answer later than this is a lost message
constexpr std::size_t fanout_subscribers = 8;
constexpr auto rate_period = 1ms;  ///< 1 kHz

/// Runs a function on a thread of its own and keeps what it throws, to rethrow on join().
class Worker {
public:
    explicit Worker(std::function<void()> body)
        : thread_([this, body = std::move(body)] {
              try {
                  body();
              } catch (...) {
                  error_ = std::current_exception();
              }
          }) {}
    ~Worker() {
        if (thread_.joinable())
            thread_.join();
    }
    Worker(const Worker&) = delete;
    Worker& operator=(const Worker&) = delete;
    void join() {
        thread_.join();
        if (error_)
            std::rethrow_exception(error_);
    }

private:
    std::exception_ptr error_;
    std::thread thread_;  // last: starts after error_ exists
};

/// Sets a flag when the scope ends, also by an exception, so that workers waiting for it end.
class SetOnExit {
public:
    explicit SetOnExit(std::atomic<bool>& flag) : flag_(flag) {}
    ~SetOnExit() { flag_ = true; }
    SetOnExit(const SetOnExit&) = delete;
    SetOnExit& operator=(const SetOnExit&) = delete;

private:
    std::atomic<bool>& flag_;
};

double microseconds(Clock::duration duration) {
    return std::chrono::duration<double, std::micro>(duration).count();
}

double peak_rss_mb(const std::vector<pid_t>& pids) {
    double total = 0;
    for (const pid_t pid : pids)
        total += static_cast<double>(std::max(0L, peak_rss_kib(pid))) / 1024.0;
    return total;
}

/// Publishes one message with `stamp`: written into a buffer the system lends where it lends one
/// (iceoryx), as the scenario writes it into its own reused `message` for the others. Either way
/// only the stamp is written per message: no system's filler is rewritten.
void send(Publisher& publisher, std::string& message, const Stamp& stamp) {
    if (const std::span<char> lent = publisher.loan(message.size()); !lent.empty()) {
        std::memcpy(lent.data(), &stamp, sizeof stamp);
        publisher.publish_loan();
        return;
    }
    put_stamp(message, stamp);
    publisher.publish(message);
}

/// Publishes warm-up messages until every subscriber has received one: subscriptions take
/// effect asynchronously on some systems (ZeroMQ's, Redis's, DDS's discovery), and first messages
/// pay for connection set-up everywhere. Warm-up messages arriving later are ignored by their kind.
void warm_up(Publisher& publisher, const std::vector<Subscriber*>& subscribers, std::size_t size) {
    std::string message(size, 'w');
    std::vector<bool> seen(subscribers.size(), false);
    Arrival arrival;
    const auto deadline = Clock::now() + warm_up_deadline;
    while (std::find(seen.begin(), seen.end(), false) != seen.end()) {
        if (Clock::now() > deadline)
            throw std::runtime_error("no message reached every subscriber within 15 s of warm-up");
        send(publisher, message, {Kind::warm_up, 0, 0, 0});
        publisher.sync();
        for (std::size_t i = 0; i < subscribers.size(); ++i) {
            if (!seen[i] && subscribers[i]->receive_stamp(arrival, 20ms))
                seen[i] = true;
        }
    }
}

/// What one subscriber saw of the data messages of a stream.
struct Reception {
    std::vector<double> latencies_us;  ///< send to receive, per message
    std::size_t received = 0;
    Clock::time_point last{};     ///< when the last data message arrived
    std::string lost_connection;  ///< why, if the connection was lost (the rest counts as lost)
};

/// Receives data messages until `expected` have arrived, or until the publisher is done and
/// nothing has come for straggler_wait (a system that drops messages).
void receive_stream(Subscriber& subscriber, std::size_t expected, const std::atomic<bool>& publisher_done,
                    Reception& reception) {
    reception.latencies_us.reserve(expected);
    Arrival arrival;
    auto quiet_since = Clock::now();
    bool saw_done = false;
    while (reception.received < expected) {
        bool got = false;
        try {
            got = subscriber.receive_stamp(arrival, receive_slice);
        } catch (const std::exception& e) {
            reception.lost_connection = e.what();
            return;
        }
        const auto now = Clock::now();
        if (!got) {
            if (publisher_done.load() && !saw_done) {
                saw_done = true;
                quiet_since = std::max(quiet_since, now - receive_slice);
            }
            if (saw_done && now - quiet_since > straggler_wait)
                return;
            continue;
        }
        if (arrival.stamp.kind != Kind::data)
            continue;
        reception.latencies_us.push_back(static_cast<double>(arrival.arrived_ns - arrival.stamp.send_ns) /
                                         1e3);
        ++reception.received;
        // When it arrived, which for a far subscriber is a moment before its report reached us.
        reception.last = Clock::time_point(
            std::chrono::duration_cast<Clock::duration>(std::chrono::nanoseconds(arrival.arrived_ns)));
        quiet_since = now;
    }
}

/// One publisher streams `count` messages (every `period`, or as fast as it can when zero) to
/// `subscriber_count` subscribers, each receiving on its own thread (or, for the systems that
/// give far subscribers, each in a process of its own, reporting to a thread here).
PeerResult stream(Broker& broker, const Workload& workload, std::size_t subscriber_count,
                  Clock::duration period) {
    std::vector<std::unique_ptr<Subscriber>> subscribers;
    std::vector<Subscriber*> subscriber_pointers;
    for (std::size_t i = 0; i < subscriber_count; ++i) {
        auto subscriber = broker.far_subscriber("stream");
        subscribers.push_back(subscriber ? std::move(subscriber) : broker.subscriber("stream"));
        subscriber_pointers.push_back(subscribers.back().get());
    }
    auto publisher =
        broker.publisher("stream", period > Clock::duration::zero() ? Traffic::latency : Traffic::bulk);
    warm_up(*publisher, subscriber_pointers, workload.size);

    std::atomic<bool> publisher_done{false};
    std::vector<Reception> receptions(subscriber_count);
    const double cpu_before = cpu_seconds(broker.pids());
    std::vector<std::unique_ptr<Worker>> workers;
    for (std::size_t i = 0; i < subscriber_count; ++i) {
        workers.push_back(std::make_unique<Worker>(
            [&, i] { receive_stream(*subscribers[i], workload.count, publisher_done, receptions[i]); }));
    }
    const SetOnExit done_on_exit(publisher_done);  // declared after the workers: ends them first
    std::string message(workload.size, 'p');
    const auto start = Clock::now();
    auto next = start;
    for (std::uint64_t seq = 0; seq < workload.count; ++seq) {
        if (period > Clock::duration::zero()) {
            std::this_thread::sleep_until(next);  // pacing the stream, not waiting for an outcome
            next += period;
        }
        send(*publisher, message, {Kind::data, 0, seq, steady_ns()});
    }
    publisher->sync();
    publisher_done = true;
    for (auto& worker : workers)
        worker->join();
    const double cpu = cpu_seconds(broker.pids()) - cpu_before;

    PeerResult result;
    std::size_t delivered = 0;
    const Reception* last_to_finish = &receptions.front();
    for (const auto& reception : receptions) {
        delivered += reception.received;
        if (reception.last > last_to_finish->last)
            last_to_finish = &reception;
        if (!reception.lost_connection.empty() && result.warning.empty())
            result.warning = "a subscriber lost its connection: " + reception.lost_connection;
    }
    if (delivered == 0)
        throw std::runtime_error("no data message was received");
    std::vector<double> latencies = last_to_finish->latencies_us;
    std::sort(latencies.begin(), latencies.end());
    const double seconds = std::chrono::duration<double>(last_to_finish->last - start).count();
    result.p50_us = percentile(latencies, 0.50);
    result.p99_us = percentile(latencies, 0.99);
    result.p999_us = percentile(latencies, 0.999);
    result.msgs_per_s = static_cast<double>(delivered) / seconds;
    result.mb_per_s = result.msgs_per_s * static_cast<double>(workload.size) / 1e6;
    result.lost = static_cast<double>(workload.count * subscriber_count - delivered);
    result.cpu_us_per_msg = cpu * 1e6 / static_cast<double>(delivered);
    result.rss_mb = peak_rss_mb(broker.pids());
    return result;
}

/// The samples of `count` timed rounds (after count/10 + 1, at most 1,000, untimed ones), and
/// the servers' CPU seconds during the timed ones. `round(seq)` does one round and returns its time.
struct Timed {
    std::vector<double> samples;
    double cpu = 0;
};
Timed time_rounds(Broker& broker, std::size_t count, const std::function<double(std::uint64_t)>& round) {
    std::uint64_t seq = 0;
    const std::size_t warm_rounds = std::min<std::size_t>(count / 10 + 1, 1000);
    for (std::size_t i = 0; i < warm_rounds; ++i)
        round(seq++);
    Timed timed;
    timed.samples.reserve(count);
    const double cpu_before = cpu_seconds(broker.pids());
    for (std::size_t i = 0; i < count; ++i)
        timed.samples.push_back(round(seq++));
    timed.cpu = cpu_seconds(broker.pids()) - cpu_before;
    return timed;
}

/// The figures of one request-and-answer run: each sample is `round_trip_per_sample` of a round
/// trip's time (2: a half round trip), and a round trip is two messages.
PeerResult result_of_rounds(Timed timed, double round_trip_per_sample, const Workload& workload,
                            Broker& broker) {
    auto& samples = timed.samples;
    PeerResult result;
    double total_us = 0;
    for (const double sample : samples)
        total_us += round_trip_per_sample * sample;
    std::sort(samples.begin(), samples.end());
    const double messages = 2.0 * static_cast<double>(workload.count);
    result.p50_us = percentile(samples, 0.50);
    result.p99_us = percentile(samples, 0.99);
    result.p999_us = percentile(samples, 0.999);
    result.msgs_per_s = messages / (total_us / 1e6);
    result.mb_per_s = result.msgs_per_s * static_cast<double>(workload.size) / 1e6;
    result.cpu_us_per_msg = timed.cpu * 1e6 / messages;
    result.rss_mb = peak_rss_mb(broker.pids());
    return result;
}

/// Echoes every data message of `echo_in` on `pong_out` until `stop`, on a thread of its own.
std::unique_ptr<Worker> echo_thread(Subscriber& echo_in, Publisher& pong_out, const std::atomic<bool>& stop) {
    return std::make_unique<Worker>([in = &echo_in, out = &pong_out, stop = &stop] {
        std::string request;
        while (!stop->load()) {
            if (in->receive(request, receive_slice) && get_stamp(request).kind == Kind::data)
                out->publish(request);
        }
    });
}

/// Request on "ping", answer on "pong", one at a time. The echo runs on a thread of its own, or
/// in a process of its own for the systems that give a far echo (it also echoes warm-ups).
PeerResult pingpong(Broker& broker, const Workload& workload) {
    auto far_echo = broker.far_echo("ping", "pong");
    std::unique_ptr<Subscriber> echo_in;
    std::unique_ptr<Publisher> pong_out;
    if (!far_echo) {
        echo_in = broker.subscriber("ping");
        pong_out = broker.publisher("pong", Traffic::latency);
    }
    auto answer_in = broker.subscriber("pong");
    auto ping_out = broker.publisher("ping", Traffic::latency);
    if (far_echo) {
        warm_up(*ping_out, {answer_in.get()}, workload.size);
    } else {
        warm_up(*ping_out, {echo_in.get()}, workload.size);
        warm_up(*pong_out, {answer_in.get()}, workload.size);
    }

    std::atomic<bool> stop{false};
    const auto echo = far_echo ? nullptr : echo_thread(*echo_in, *pong_out, stop);
    const SetOnExit stop_on_exit(stop);  // declared after the echo: ends it before it is joined
    std::string message(workload.size, 'q');
    Arrival answer;
    auto half_round_trip = [&](std::uint64_t seq) {
        const auto sent = Clock::now();
        send(*ping_out, message, {Kind::data, 0, seq, 0});
        for (;;) {
            if (!answer_in->receive_stamp(answer, ping_pong_answer_wait))
                throw std::runtime_error("a ping-pong message was lost (no answer within 5 s)");
            if (answer.stamp.kind == Kind::data && answer.stamp.seq == seq)
                break;
        }
        const double half = microseconds(Clock::now() - sent) / 2;
        ping_out->sync();  // outside the timed part: e.g. reads Redis's answer to PUBLISH
        return half;
    };
    Timed timed = time_rounds(broker, workload.count, half_round_trip);
    stop = true;
    if (echo)
        echo->join();
    return result_of_rounds(std::move(timed), 2, workload, broker);
}

/// A request and its answer, one at a time, through the system's own request/reply.
PeerResult requestreply(Broker& broker, const Workload& workload) {
    auto responder = broker.responder("service");
    auto requester = broker.requester("service");
    if (!responder || !requester)
        throw std::runtime_error("this system has no request/reply in the bench");
    std::string message(workload.size, 'q');
    std::string answer;
    // Until the responder's subscription is in effect, requests may go unanswered.
    const auto ready_by = Clock::now() + ping_pong_answer_wait;
    while (!requester->request(message, answer, std::chrono::milliseconds(200))) {
        if (Clock::now() > ready_by)
            throw std::runtime_error("no answer to a request within 5 s");
    }
    auto round_trip = [&](std::uint64_t seq) {
        put_stamp(message, {Kind::data, 0, seq, 0});
        const auto sent = Clock::now();
        if (!requester->request(message, answer, ping_pong_answer_wait))
            throw std::runtime_error("a request was not answered within 5 s");
        const double took = microseconds(Clock::now() - sent);
        if (answer.size() != message.size() || get_stamp(answer).seq != seq)
            throw std::runtime_error("an answer that is not its request's");
        return took;
    };
    return result_of_rounds(time_rounds(broker, workload.count, round_trip), 1, workload, broker);
}

}  // namespace

const std::vector<Scenario>& all_scenarios() {
    static const std::vector<Scenario> scenarios{Scenario::pingpong, Scenario::rate_1khz,
                                                 Scenario::throughput, Scenario::fanout_8};
    return scenarios;
}

const std::vector<Scenario>& known_scenarios() {
    static const std::vector<Scenario> scenarios{Scenario::pingpong, Scenario::rate_1khz,
                                                 Scenario::throughput, Scenario::fanout_8,
                                                 Scenario::requestreply};
    return scenarios;
}

std::string name_of(Scenario scenario) {
    switch (scenario) {
        case Scenario::pingpong:
            return "pingpong";
        case Scenario::rate_1khz:
            return "rate_1khz";
        case Scenario::throughput:
            return "throughput";
        case Scenario::fanout_8:
            return "fanout_8";
        case Scenario::requestreply:
            return "requestreply";
    }
    return "?";
}

PeerResult run_scenario(Scenario scenario, Broker& broker, const Workload& workload) {
    if (workload.size < min_message_size)
        throw std::invalid_argument("messages must be at least " + std::to_string(min_message_size) +
                                    " bytes");
    switch (scenario) {
        case Scenario::pingpong:
            return pingpong(broker, workload);
        case Scenario::rate_1khz:
            return stream(broker, workload, 1, rate_period);
        case Scenario::throughput:
            return stream(broker, workload, 1, Clock::duration::zero());
        case Scenario::fanout_8:
            return stream(broker, workload, fanout_subscribers, Clock::duration::zero());
        case Scenario::requestreply:
            return requestreply(broker, workload);
    }
    throw std::logic_error("unknown scenario");
}

std::size_t default_count(Scenario scenario, std::size_t size, bool quick) {
    const std::size_t bytes = std::max<std::size_t>(size, 1);
    std::size_t count = 0;
    switch (scenario) {
        case Scenario::pingpong:
        case Scenario::requestreply:
            count = std::clamp<std::size_t>((8u << 20) / bytes, 100, 5000);
            break;
        case Scenario::rate_1khz:
            count = size >= (1u << 20) ? 500 : 1000;  // milliseconds at 1 kHz
            break;
        case Scenario::throughput:
            count = std::clamp<std::size_t>((64u << 20) / bytes, 100, 100000);
            break;
        case Scenario::fanout_8:
            count = std::clamp<std::size_t>((16u << 20) / bytes, 50, 20000);
            break;
    }
    return quick ? std::max<std::size_t>(count / 10, 30) : count;
}

}  // namespace plexus::bench::peers
