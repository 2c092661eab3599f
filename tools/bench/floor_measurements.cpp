#include "floor_measurements.hpp"

#include <mutex>
#include <stdexcept>
#include <thread>

#include "floor_frame.hpp"
#include "floor_socket.hpp"
#include "process_stats.hpp"

namespace plexus::bench {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

void check_payload(const FloorFrame& frame, std::size_t size) {
    if (frame.payload.size() != size) {
        throw std::runtime_error("floor: got a " + std::to_string(frame.payload.size()) +
                                 "-byte payload, expected " + std::to_string(size));
    }
}

/// What a ping-pong reports: half the round trip (latency) or all of it (a call's floor).
enum class Timed { half_round_trip, round_trip };

class FloorLatency : public Measurement {
public:
    FloorLatency(FloorEnds ends, const Options& options, Timed timed)
        : pids_(std::move(ends.pids)),
          divisor_(timed == Timed::half_round_trip ? 2.0 : 1.0),
          size_(options.size),
          count_(latency_count(options)),
          payload_(options.size, 0x5a),
          near_(std::move(ends.near)),
          far_(std::move(ends.far)) {
        near_->set_read_timeout(stall_timeout);
        far_->set_read_timeout(200ms);
        echo_ = std::jthread([this](const std::stop_token& stop) { echo(stop); });
    }

    ~FloorLatency() override {
        echo_.request_stop();
        try {
            near_->write(floor_frame::stop_seq, 0, {}, true);
        } catch (...) {
            // The echo thread also stops on its own within one read timeout.
        }
    }

    RunResult run() override {
        return time_round_trips(count_, size_, pids_, [this] { return round_trip(); });
    }

private:
    double round_trip() {
        const auto sent = Clock::now();
        near_->write(seq_, now_ns(), payload_, true);
        const auto reply = near_->read();
        const auto back = Clock::now();
        if (!reply) {
            std::lock_guard lock(echo_error_mutex_);
            throw std::runtime_error("floor: no echo within 10 s" +
                                     (echo_error_.empty() ? "" : ": " + echo_error_));
        }
        if (reply->seq != seq_)
            throw std::runtime_error("floor: echo of the wrong frame");
        ++seq_;
        check_payload(*reply, size_);
        return std::chrono::duration<double, std::micro>(back - sent).count() / divisor_;
    }

    void echo(const std::stop_token& stop) {
        try {
            while (!stop.stop_requested()) {
                const auto frame = far_->read();
                if (!frame)
                    continue;  // read timeout: look at the stop token again
                if (frame->seq == floor_frame::stop_seq)
                    return;
                far_->write(frame->seq, frame->time_ns, frame->payload, true);
            }
        } catch (const std::exception& e) {
            std::lock_guard lock(echo_error_mutex_);
            echo_error_ = e.what();
        }
    }

    std::vector<pid_t> pids_;
    double divisor_;
    std::size_t size_;
    std::size_t count_;
    std::vector<std::uint8_t> payload_;
    std::uint64_t seq_ = 1;
    std::unique_ptr<FloorSocket> near_;
    std::unique_ptr<FloorSocket> far_;
    std::mutex echo_error_mutex_;
    std::string echo_error_;
    std::jthread echo_;  // last: joined before the sockets it uses are destroyed
};

class FloorThroughput : public Measurement {
public:
    FloorThroughput(FloorEnds ends, const Options& options)
        : pids_(std::move(ends.pids)),
          size_(options.size),
          count_(throughput_count(options)),
          payload_(options.size, 0x5a),
          writer_(std::move(ends.near)),
          reader_(std::move(ends.far)) {
        writer_->set_read_timeout(stall_timeout);
        reader_->set_read_timeout(stall_timeout);
        stream(std::max<std::size_t>(count_ / 10, 10));  // warm-up, as for Plexus
    }

    RunResult run() override {
        const double cpu_before = cpu_seconds(pids_);
        const auto start = Clock::now();
        auto [latencies, last] = stream(count_);
        const double cpu = cpu_seconds(pids_) - cpu_before;
        return summarize(latencies, count_, size_, last - start, cpu);
    }

private:
    struct Streamed {
        std::vector<double> latencies_us;
        Clock::time_point last;
    };

    Streamed stream(std::size_t count) {
        Streamed streamed;
        streamed.latencies_us.reserve(count);
        std::string error;
        std::jthread reader([&] {
            try {
                for (std::size_t i = 0; i < count; ++i) {
                    const auto frame = reader_->read();
                    const std::uint64_t arrived = now_ns();
                    if (!frame)
                        throw std::runtime_error("floor: message " + std::to_string(i) + " never arrived");
                    if (frame->seq != next_read_) {
                        throw std::runtime_error("floor: expected seq " + std::to_string(next_read_) +
                                                 ", got " + std::to_string(frame->seq));
                    }
                    ++next_read_;
                    check_payload(*frame, size_);
                    streamed.latencies_us.push_back(static_cast<double>(arrived - frame->time_ns) / 1e3);
                }
                streamed.last = Clock::now();
            } catch (const std::exception& e) {
                error = e.what();
            }
        });
        // The send time is taken per message, like libplexus does for the envelope.
        for (std::size_t i = 0; i < count; ++i)
            writer_->write(next_write_++, now_ns(), payload_, false);
        writer_->flush();
        reader.join();
        if (!error.empty())
            throw std::runtime_error(error);
        return streamed;
    }

    std::vector<pid_t> pids_;
    std::size_t size_;
    std::size_t count_;
    std::vector<std::uint8_t> payload_;
    std::unique_ptr<FloorSocket> writer_;
    std::unique_ptr<FloorSocket> reader_;
    std::uint64_t next_write_ = 1;
    std::uint64_t next_read_ = 1;
};

FloorEnds relay_ends(const Topology& topology) {
    return {std::make_unique<FloorSocket>(topology.near_socket(), stall_timeout),
            std::make_unique<FloorSocket>(topology.far_socket(), stall_timeout), topology.pids()};
}

}  // namespace

std::unique_ptr<Measurement> floor_latency(const Topology& topology, const Options& options) {
    return std::make_unique<FloorLatency>(relay_ends(topology), options, Timed::half_round_trip);
}

std::unique_ptr<Measurement> floor_round_trip(const Topology& topology, const Options& options) {
    return std::make_unique<FloorLatency>(relay_ends(topology), options, Timed::round_trip);
}

std::unique_ptr<Measurement> floor_throughput(const Topology& topology, const Options& options) {
    return std::make_unique<FloorThroughput>(relay_ends(topology), options);
}

std::unique_ptr<Measurement> floor_latency_between(FloorEnds ends, const Options& options) {
    return std::make_unique<FloorLatency>(std::move(ends), options, Timed::half_round_trip);
}

std::unique_ptr<Measurement> floor_round_trip_between(FloorEnds ends, const Options& options) {
    return std::make_unique<FloorLatency>(std::move(ends), options, Timed::round_trip);
}

std::unique_ptr<Measurement> floor_throughput_between(FloorEnds ends, const Options& options) {
    return std::make_unique<FloorThroughput>(std::move(ends), options);
}

}  // namespace plexus::bench
