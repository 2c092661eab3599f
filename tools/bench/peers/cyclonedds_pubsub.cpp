// Cyclone DDS (0.10, Debian's), the DDS of ROS 2's default middleware, through its C API: the
// systems `cyclonedds` (reliable, ROS 2's default) and `cyclonedds-be` (best effort). Fairness
// choices, each also in docs/BENCHMARKS.md:
// - Processes. DDS hands a message from a writer to a reader of the same process without the
//   network, which two nodes of a robot never get; so the far end of every scenario (a stream's
//   subscribers, the ping-pong's echo) is a process of its own (far_end.hpp), and each run is a
//   process of its own too (own_process_run.hpp): the publisher and the ping-pong's answer reader
//   live there. One participant per process, as ROS 2 makes one per process.
// - Network. Each run process enters a network namespace of its own with only loopback, up and
//   multicast-capable (private_network.hpp): discovery and data never touch this machine's
//   interfaces nor meet another DDS program, and Cyclone keeps its default configuration
//   (CYCLONEDDS_URI is cleared): multicast discovery, UDP, its default fragment and socket sizes.
// - QoS. Default but for reliability (reliable or best effort, by system) and history: keep-all
//   on writer and reader, so that a reliable stream loses nothing and the writer blocks when
//   unacknowledged data passes Cyclone's default watermark (DDS's own flow control). Keep-last does
//   not do that in Cyclone 0.10.2, measured on a 20,000 x 4 KiB throughput run: with ROS 2's depth
//   10, or 1,000, its writer drops unacknowledged samples that fall out of the depth and the
//   reliable stream lost 74-86 % of its messages; with a depth past the run's count (100,000) it
//   lost none but crawled (4-12 k msgs/s, p50 of seconds), against 112 k msgs/s and a p50 of
//   129 us with keep-all. max_blocking_time stays at its default (100 ms); a write that times out
//   is tried again, for up to 10 s.
// - Reading. Readers wait on a waitset (they sleep, as Plexus's readers and ROS 2's executors do)
//   and take samples as loans: the stamp is read where Cyclone deserialized the sample, and nothing
//   is copied out of it (Cyclone's own copy into the sample is DDS's cost). The echo writes back
//   the sample it took.
// - No broker process: CPU and memory per message are 0 (what the far ends use is not counted,
//   as no system's subscribers are).
#include <dds/dds.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "far_end.hpp"
#include "peer_systems.hpp"
#include "peers_payload.h"
#include "private_network.hpp"

namespace plexus::bench::peers {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr const char* reliable_name = "cyclonedds";
constexpr const char* best_effort_name = "cyclonedds-be";
constexpr auto write_retry_limit = 10s;
constexpr uint32_t take_batch = 64;  ///< samples a far end takes at once

void check(dds_return_t code, const std::string& what) {
    if (code < 0)
        throw std::runtime_error("cyclonedds: " + what + ": " + dds_strretcode(-code));
}

/// An entity (participant, and with it all it made) deleted with its handle.
class Entity {
public:
    explicit Entity(dds_entity_t entity, const std::string& what) : entity_(entity) { check(entity, what); }
    ~Entity() { dds_delete(entity_); }
    Entity(const Entity&) = delete;
    Entity& operator=(const Entity&) = delete;
    dds_entity_t get() const { return entity_; }

private:
    dds_entity_t entity_;
};

dds_qos_t* make_qos(bool reliable) {
    dds_qos_t* qos = dds_create_qos();
    // DDS_MSECS(100): Cyclone's default max_blocking_time, restated because the call needs one.
    dds_qset_reliability(qos, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                         DDS_MSECS(100));
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
    return qos;
}

dds_entity_t make_topic(dds_entity_t participant, const std::string& name) {
    const dds_entity_t topic =
        dds_create_topic(participant, &plexus_bench_Payload_desc, name.c_str(), nullptr, nullptr);
    check(topic, "create topic " + name);
    return topic;
}

dds_entity_t make_writer(dds_entity_t participant, const std::string& topic, bool reliable) {
    dds_qos_t* qos = make_qos(reliable);
    const dds_entity_t writer = dds_create_writer(participant, make_topic(participant, topic), qos, nullptr);
    dds_delete_qos(qos);
    check(writer, "create writer on " + topic);
    return writer;
}

dds_entity_t make_reader(dds_entity_t participant, const std::string& topic, bool reliable) {
    dds_qos_t* qos = make_qos(reliable);
    const dds_entity_t reader = dds_create_reader(participant, make_topic(participant, topic), qos, nullptr);
    dds_delete_qos(qos);
    check(reader, "create reader on " + topic);
    return reader;
}

/// Writes `sample`; a reliable writer blocked past max_blocking_time tries again.
void write_sample(dds_entity_t writer, const plexus_bench_Payload& sample) {
    const auto give_up = Clock::now() + write_retry_limit;
    for (;;) {
        const dds_return_t result = dds_write(writer, &sample);
        if (result != DDS_RETCODE_TIMEOUT || Clock::now() > give_up)
            return check(result, "write");
    }
}

/// A waitset that wakes when `reader` has samples.
dds_entity_t make_waitset(dds_entity_t participant, dds_entity_t reader) {
    const dds_entity_t waitset = dds_create_waitset(participant);
    check(waitset, "create waitset");
    const dds_entity_t readable = dds_create_readcondition(reader, DDS_ANY_STATE);
    check(readable, "create read condition");
    check(dds_waitset_attach(waitset, readable, 0), "attach read condition");
    return waitset;
}

bool is_reliable(const std::string& system) {
    if (system == reliable_name)
        return true;
    if (system == best_effort_name)
        return false;
    throw std::invalid_argument("not a Cyclone DDS system: " + system);
}

class DdsPublisher final : public Publisher {
public:
    DdsPublisher(dds_entity_t participant, const std::string& topic, bool reliable)
        : writer_(make_writer(participant, topic, reliable)) {}

    void publish(std::string_view payload) override {
        plexus_bench_Payload sample{};
        // Lent to dds_write, which serializes it before it returns; _release false: not Cyclone's to free.
        sample.data._buffer = reinterpret_cast<uint8_t*>(const_cast<char*>(payload.data()));
        sample.data._length = sample.data._maximum = static_cast<uint32_t>(payload.size());
        sample.data._release = false;
        write_sample(writer_, sample);
    }

private:
    dds_entity_t writer_;  // deleted with the participant
};

/// A reader in the measuring process (the ping-pong's answers).
class DdsSubscriber final : public Subscriber {
public:
    DdsSubscriber(dds_entity_t participant, const std::string& topic, bool reliable)
        : reader_(make_reader(participant, topic, reliable)), waitset_(make_waitset(participant, reader_)) {}

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        return take_one(timeout, [&](const plexus_bench_Payload& sample) {
            payload.assign(reinterpret_cast<const char*>(sample.data._buffer), sample.data._length);
        });
    }

    bool receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) override {
        return take_one(timeout, [&](const plexus_bench_Payload& sample) {
            arrival.arrived_ns = steady_ns();
            arrival.stamp = Stamp{};
            arrival.stamp.kind = Kind{0};
            if (sample.data._length >= sizeof arrival.stamp)
                std::memcpy(&arrival.stamp, sample.data._buffer, sizeof arrival.stamp);
        });
    }

private:
    template <typename Use>
    bool take_one(std::chrono::milliseconds timeout, Use use) {
        const auto deadline = Clock::now() + timeout;
        for (;;) {
            void* samples[1] = {nullptr};
            dds_sample_info_t info;
            const dds_return_t taken = dds_take(reader_, samples, &info, 1, 1);
            check(taken, "take");
            if (taken == 1) {
                if (info.valid_data)
                    use(*static_cast<const plexus_bench_Payload*>(samples[0]));
                dds_return_loan(reader_, samples, 1);
                if (info.valid_data)
                    return true;
                continue;  // a change of the writer's state, not a message
            }
            const auto left = deadline - Clock::now();
            if (left <= Clock::duration::zero())
                return false;
            const dds_return_t woken = dds_waitset_wait(
                waitset_, nullptr, 0, std::chrono::duration_cast<std::chrono::nanoseconds>(left).count());
            check(woken, "wait");
        }
    }

    dds_entity_t reader_;  // deleted with the participant
    dds_entity_t waitset_;
};

class DdsBroker final : public Broker {
public:
    DdsBroker(const BrokerSetup& setup, std::string system)
        : dir_(setup.dir), self_(setup.self), system_(std::move(system)), reliable_(is_reliable(system_)) {
        enter_private_network();
        // The default configuration, whatever this environment would set.
        ::unsetenv("CYCLONEDDS_URI");
        participant_ = std::make_unique<Entity>(dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr),
                                                "create participant");
    }

    std::vector<pid_t> pids() const override { return {}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic /*traffic*/) override {
        return std::make_unique<DdsPublisher>(participant_->get(), topic, reliable_);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<DdsSubscriber>(participant_->get(), topic, reliable_);
    }

    std::unique_ptr<Subscriber> far_subscriber(const std::string& topic) override {
        return std::make_unique<FarSubscriber>(far_end_command(self_, system_), topic, dir_);
    }

    std::unique_ptr<Echo> far_echo(const std::string& from, const std::string& to) override {
        return std::make_unique<FarEcho>(far_end_command(self_, system_), from, to, dir_);
    }

private:
    const TempDir& dir_;
    std::string self_;
    std::string system_;
    bool reliable_;
    std::unique_ptr<Entity> participant_;
};

/// Takes what `reader` has, in batches, handing each valid sample to `use`; waits for more until
/// SIGTERM. `after_batch` runs when the reader is empty and says how long the next wait may be
/// (nullopt: stop).
template <typename Use, typename AfterBatch>
void take_until_stopped(dds_entity_t participant, dds_entity_t reader, Use use, AfterBatch after_batch) {
    const dds_entity_t waitset = make_waitset(participant, reader);
    std::vector<void*> samples(take_batch, nullptr);
    std::vector<dds_sample_info_t> infos(take_batch);
    for (NextWait wait = keep_waiting(); wait && !far_end_stopping(); wait = after_batch()) {
        const dds_return_t woken = dds_waitset_wait(
            waitset, nullptr, 0, std::chrono::duration_cast<std::chrono::nanoseconds>(*wait).count());
        if (woken < 0 && far_end_stopping())
            return;
        check(woken, "wait");
        for (;;) {
            std::fill(samples.begin(), samples.end(), nullptr);  // null: lend me Cyclone's samples
            const dds_return_t taken = dds_take(reader, samples.data(), infos.data(), take_batch, take_batch);
            check(taken, "take");
            if (taken <= 0)
                break;
            const std::int64_t now = steady_ns();
            for (dds_return_t i = 0; i < taken; ++i) {
                if (infos[static_cast<std::size_t>(i)].valid_data)
                    use(*static_cast<const plexus_bench_Payload*>(samples[static_cast<std::size_t>(i)]), now);
            }
            dds_return_loan(reader, samples.data(), taken);
            if (taken < static_cast<dds_return_t>(take_batch))
                break;
        }
    }
}

}  // namespace

System cyclonedds_system() {
    System system{reliable_name,
                  [](const BrokerSetup& setup) { return std::make_unique<DdsBroker>(setup, reliable_name); }};
    system.own_process = true;
    return system;
}

System cyclonedds_best_effort_system() {
    System system{best_effort_name, [](const BrokerSetup& setup) {
                      return std::make_unique<DdsBroker>(setup, best_effort_name);
                  }};
    system.own_process = true;
    return system;
}

int run_cyclonedds_far_end(const FarEndOptions& options) {
    stop_far_end_on_sigterm();
    const bool reliable = is_reliable(options.system);
    // Already inside the run process's namespace (inherited); the same default configuration.
    ::unsetenv("CYCLONEDDS_URI");
    const Entity participant(dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr),
                             "create participant");
    const dds_entity_t reader = make_reader(participant.get(), options.topic, reliable);
    if (options.role == "subscriber") {
        ReportWriter reports(options.report);
        take_until_stopped(
            participant.get(), reader,
            [&](const plexus_bench_Payload& sample, std::int64_t now) {
                Stamp stamp{};
                stamp.kind = Kind{0};
                if (sample.data._length >= sizeof stamp)
                    std::memcpy(&stamp, sample.data._buffer, sizeof stamp);
                reports.add(stamp, now);
            },
            [&] { return reports.after_batch(); });
        return 0;
    }
    if (options.role == "echo") {
        const dds_entity_t writer = make_writer(participant.get(), options.answer_topic, reliable);
        take_until_stopped(
            participant.get(), reader,
            [&](const plexus_bench_Payload& sample, std::int64_t /*now*/) { write_sample(writer, sample); },
            keep_waiting);
        return 0;
    }
    throw std::invalid_argument("unknown far-end role '" + options.role + "'");
}

}  // namespace plexus::bench::peers
