// iceoryx (2.0, Debian's): zero-copy shared memory between processes of one machine, with RouDi
// as its daemon, through its C++ untyped publisher and subscriber: the system `iceoryx`. Fairness
// choices, each also in docs/BENCHMARKS.md:
// - Processes. As for DDS: each run is a process of its own (iceoryx's runtime registers with one
//   RouDi per process lifetime, and each run has a fresh RouDi), and the far end of every scenario
//   (a stream's subscribers, the ping-pong's echo) is another process (far_end.hpp).
// - RouDi. Started by the run (roudi_process.hpp) with one mempool of chunks that fit the run's
//   message size exactly; 280 of them: the subscriber queue's default capacity (256), one chunk
//   held by each of up to 8 subscribers, the 8 a publisher may hold at once, 8 spare. A message is
//   never too large: the pool is made for it. RouDi reserves and touches the whole pool up front, so
//   past 1 MiB messages (which the default sizes do not pass) the queue is shortened to keep the
//   pool within 512 MiB. RouDi's CPU and memory (the pool included) are what the figures count.
// - Loans. The publisher loans a chunk, the scenario writes its stamp into it in place, the chunk
//   is published: the scenario writes only the stamp per message, as it does into its reused
//   buffer for every other system (Publisher::loan). The subscriber takes the chunk, reads the
//   stamp where it lies and releases it: zero copies, which is what iceoryx is for. The echo
//   answers with a chunk of the same size carrying the same stamp, written in place likewise.
// - No drops. Publishers wait for a full subscriber queue (WAIT_FOR_CONSUMER) and subscribers ask
//   for that (BLOCK_PRODUCER), iceoryx's documented lossless mode, instead of the default
//   DISCARD_OLDEST_DATA that would make throughput rows count drops. Queue capacity: the default.
// - Waiting. Subscribers sleep on a WaitSet until data arrives, as Plexus's readers sleep; no one
//   busy-waits (iceoryx's own iceperf polls, which a 2-core machine shared with the publisher
//   would pay for). A blocked publisher waits the way iceoryx makes it wait.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

#include "far_end.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/mepoo/chunk_header.hpp"
#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "iceoryx_posh/popo/untyped_subscriber.hpp"
#include "iceoryx_posh/popo/wait_set.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "peer_systems.hpp"
#include "roudi_process.hpp"

namespace plexus::bench::peers {

namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* system_name = "iceoryx";
constexpr std::size_t default_queue = 256;  ///< iceoryx 2.0's default (and largest) queue capacity
constexpr std::size_t max_subscribers = 8;  ///< the fan-out's
constexpr std::size_t publisher_loans = 8;  ///< IOX_MAX_CHUNKS_ALLOCATED_PER_PUBLISHER_SIMULTANEOUSLY
constexpr std::size_t spare_chunks = 8;
/// Chunks needed beside those in a subscriber queue (which, blocking, all subscribers share).
constexpr std::size_t chunks_beside_queue = max_subscribers + publisher_loans + spare_chunks;
constexpr std::size_t pool_budget = std::size_t{512} << 20;
constexpr std::uint32_t payload_alignment = alignof(Stamp);

/// The service of a topic: iceoryx names a topic by three strings.
iox::capro::ServiceDescription service_of(const std::string& topic) {
    return {"PlexusBench", iox::capro::IdString_t(iox::cxx::TruncateToCapacity, topic.c_str()), "Payload"};
}

iox::popo::PublisherOptions publisher_options() {
    iox::popo::PublisherOptions options;
    options.subscriberTooSlowPolicy = iox::popo::ConsumerTooSlowPolicy::WAIT_FOR_CONSUMER;
    return options;
}

/// The subscriber queue's capacity for chunks of `chunk_size` bytes: iceoryx's default, unless the
/// pool that needs would pass pool_budget.
std::size_t queue_capacity_for(std::size_t chunk_size) {
    const std::size_t affordable = pool_budget / chunk_size;
    return std::clamp<std::size_t>(affordable > chunks_beside_queue ? affordable - chunks_beside_queue : 1, 1,
                                   default_queue);
}

iox::popo::SubscriberOptions subscriber_options(std::size_t queue_capacity) {
    iox::popo::SubscriberOptions options;
    options.queueCapacity = queue_capacity;
    options.queueFullPolicy = iox::popo::QueueFullPolicy::BLOCK_PRODUCER;
    return options;
}

iox::units::Duration iox_duration(std::chrono::nanoseconds duration) {
    return iox::units::Duration::fromNanoseconds(
        static_cast<std::uint64_t>(std::max<std::int64_t>(duration.count(), 0)));
}

void init_runtime(const std::string& role) {
    // iceoryx logs every registration at its default level (verbose); warnings are what a run's log
    // should hold.
    iox::log::LogManager::GetLogManager().SetDefaultLogLevel(iox::log::LogLevel::kWarn,
                                                             iox::log::LogLevelOutput::kHideLogLevel);
    const std::string name = "plexus-bench-" + role + "-" + std::to_string(::getpid());
    iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
}

Stamp stamp_in(const void* payload) {
    Stamp stamp;
    std::memcpy(&stamp, payload, sizeof stamp);  // every chunk holds at least a stamp (min_message_size)
    return stamp;
}

/// A publisher that lends its chunks.
class IceoryxPublisher final : public Publisher {
public:
    explicit IceoryxPublisher(const std::string& topic)
        : publisher_(service_of(topic), publisher_options()) {}

    std::span<char> loan(std::size_t size) override {
        auto chunk = publisher_.loan(static_cast<std::uint32_t>(size), payload_alignment);
        if (chunk.has_error())
            throw std::runtime_error("iceoryx: cannot loan a chunk of " + std::to_string(size) +
                                     " bytes (error " + std::to_string(static_cast<int>(chunk.get_error())) +
                                     ")");
        loaned_ = chunk.value();
        return {static_cast<char*>(loaned_), size};
    }

    void publish_loan() override {
        publisher_.publish(loaned_);
        loaned_ = nullptr;
    }

    // Not used by the scenarios (they write into loans): a copy into a loaned chunk.
    void publish(std::string_view payload) override {
        const std::span<char> chunk = loan(payload.size());
        std::memcpy(chunk.data(), payload.data(), payload.size());
        publish_loan();
    }

private:
    iox::popo::UntypedPublisher publisher_;
    void* loaned_ = nullptr;
};

/// A subscriber in the measuring process (the ping-pong's answers), sleeping on a WaitSet.
class IceoryxSubscriber final : public Subscriber {
public:
    IceoryxSubscriber(const std::string& topic, std::size_t queue_capacity)
        : subscriber_(service_of(topic), subscriber_options(queue_capacity)) {
        if (waitset_.attachState(subscriber_, iox::popo::SubscriberState::HAS_DATA).has_error())
            throw std::runtime_error("iceoryx: cannot attach a subscriber to a WaitSet");
    }
    ~IceoryxSubscriber() override { waitset_.detachState(subscriber_, iox::popo::SubscriberState::HAS_DATA); }
    IceoryxSubscriber(const IceoryxSubscriber&) = delete;
    IceoryxSubscriber& operator=(const IceoryxSubscriber&) = delete;

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        return take_one(timeout, [&](const void* chunk) {
            const auto* header = iox::mepoo::ChunkHeader::fromUserPayload(chunk);
            payload.assign(static_cast<const char*>(chunk), header->userPayloadSize());
        });
    }

    bool receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) override {
        return take_one(timeout, [&](const void* chunk) {
            arrival.arrived_ns = steady_ns();
            arrival.stamp = stamp_in(chunk);
        });
    }

private:
    template <typename Use>
    bool take_one(std::chrono::milliseconds timeout, Use use) {
        const auto deadline = Clock::now() + timeout;
        for (;;) {
            auto taken = subscriber_.take();
            if (!taken.has_error()) {
                use(taken.value());
                subscriber_.release(taken.value());
                return true;
            }
            const auto left = deadline - Clock::now();
            if (left <= Clock::duration::zero())
                return false;
            waitset_.timedWait(iox_duration(left));
        }
    }

    iox::popo::UntypedSubscriber subscriber_;
    iox::popo::WaitSet<> waitset_;  // declared after the subscriber: detached before it goes
};

class IceoryxBroker final : public Broker {
public:
    explicit IceoryxBroker(const BrokerSetup& setup)
        : dir_(setup.dir),
          self_(setup.self),
          chunk_size_(chunk_size(setup.message_size)),
          queue_capacity_(queue_capacity_for(chunk_size_)),
          roudi_(setup.dir, chunk_size_, queue_capacity_ + chunks_beside_queue) {
        init_runtime("run");
    }

    std::vector<pid_t> pids() const override { return {roudi_.pid()}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic /*traffic*/) override {
        return std::make_unique<IceoryxPublisher>(topic);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<IceoryxSubscriber>(topic, queue_capacity_);
    }

    std::unique_ptr<Subscriber> far_subscriber(const std::string& topic) override {
        return std::make_unique<FarSubscriber>(far_end(), topic, dir_);
    }

    std::unique_ptr<Echo> far_echo(const std::string& from, const std::string& to) override {
        return std::make_unique<FarEcho>(far_end(), from, to, dir_);
    }

private:
    std::vector<std::string> far_end() const {
        auto command = far_end_command(self_, system_name);
        command.insert(command.end(), {"--queue-capacity", std::to_string(queue_capacity_)});
        return command;
    }

    /// The run's message size, at least a stamp, rounded up to iceoryx's 8-byte chunk granularity.
    static std::size_t chunk_size(std::size_t message_size) {
        const std::size_t size = std::max(message_size, min_message_size);
        return (size + 7) / 8 * 8;
    }

    const TempDir& dir_;
    std::string self_;
    std::size_t chunk_size_;
    std::size_t queue_capacity_;
    RoudiProcess roudi_;  // after the sizes it is made with
};

/// Takes every chunk `subscriber` has, one at a time, handing each to `use`, and sleeps on a
/// WaitSet for more, until SIGTERM. `after_batch` runs when the subscriber is empty and says how
/// long the next wait may be (nullopt: stop).
template <typename Use, typename AfterBatch>
void take_until_stopped(iox::popo::UntypedSubscriber& subscriber, Use use, AfterBatch after_batch) {
    iox::popo::WaitSet<> waitset;
    if (waitset.attachState(subscriber, iox::popo::SubscriberState::HAS_DATA).has_error())
        throw std::runtime_error("iceoryx: cannot attach a subscriber to a WaitSet");
    for (NextWait wait = keep_waiting(); wait && !far_end_stopping(); wait = after_batch()) {
        waitset.timedWait(iox_duration(*wait));
        for (auto taken = subscriber.take(); !taken.has_error(); taken = subscriber.take()) {
            use(taken.value(), steady_ns());
            subscriber.release(taken.value());
        }
    }
    waitset.detachState(subscriber, iox::popo::SubscriberState::HAS_DATA);
}

}  // namespace

System iceoryx_system() {
    System system{system_name,
                  [](const BrokerSetup& setup) { return std::make_unique<IceoryxBroker>(setup); }};
    system.own_process = true;
    return system;
}

int run_iceoryx_far_end(const FarEndOptions& options) {
    stop_far_end_on_sigterm();
    init_runtime("far");
    const std::size_t queue_capacity = options.queue_capacity > 0 ? options.queue_capacity : default_queue;
    iox::popo::UntypedSubscriber subscriber(service_of(options.topic), subscriber_options(queue_capacity));
    if (options.role == "subscriber") {
        ReportWriter reports(options.report);
        take_until_stopped(
            subscriber, [&](const void* chunk, std::int64_t now) { reports.add(stamp_in(chunk), now); },
            [&] { return reports.after_batch(); });
        return 0;
    }
    if (options.role == "echo") {
        iox::popo::UntypedPublisher answers(service_of(options.answer_topic), publisher_options());
        take_until_stopped(
            subscriber,
            [&](const void* chunk, std::int64_t /*now*/) {
                const auto size = iox::mepoo::ChunkHeader::fromUserPayload(chunk)->userPayloadSize();
                auto answer = answers.loan(size, payload_alignment);
                if (answer.has_error())
                    throw std::runtime_error("iceoryx: the echo cannot loan a chunk of " +
                                             std::to_string(size) + " bytes");
                const Stamp stamp = stamp_in(chunk);
                std::memcpy(answer.value(), &stamp, sizeof stamp);
                answers.publish(answer.value());
            },
            keep_waiting);
        return 0;
    }
    throw std::invalid_argument("unknown far-end role '" + options.role + "'");
}

}  // namespace plexus::bench::peers
