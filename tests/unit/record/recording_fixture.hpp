#pragma once
// Recordings written by the tests with the MCAP writer in the layout the daemon's recorder uses
// (recording_layout.hpp), and a live arbitration to fill in their decisions: the daemon's own
// Arbiter, members and monitors, driven message by message as the daemon drives them.

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "arbitration/arbiter.hpp"
#include "arbitration/carrier_rules.hpp"
#include "arbitration/clock.hpp"
#include "core/message.hpp"
#include "monitor/carrier_monitors.hpp"
#include "plexus/mcap/recording_layout.hpp"
#include "plexus/mcap/writer.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::record::test {

namespace layout = mcap::layout;
namespace arbitration = daemon::arbitration;
namespace monitor = daemon::monitor;

inline constexpr std::uint64_t started_unix_ns = 1'700'000'000'000'000'000ull;
inline constexpr double started_clock = 1000.0;

/// A directory of its own for one test, removed at the end.
class TempDir {
public:
    TempDir() {
        static std::atomic<int> counter{0};
        path_ = std::filesystem::temp_directory_path() /
                ("plexus-what-if-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    std::string file(const std::string& name) const { return (path_ / name).string(); }
    void write(const std::string& name, const std::string& text) const { std::ofstream(file(name)) << text; }

private:
    std::filesystem::path path_;
};

/// Writes a recording of one port, entry by entry.
class RecordingWriter {
public:
    RecordingWriter(const std::string& path, std::string port) : port_(std::move(port)) {
        auto created = mcap::Writer::create(path);
        EXPECT_TRUE(created.ok()) << (created.ok() ? "" : created.error().message);
        writer_ = std::move(*created);
        writer_->write_metadata(std::string(layout::recording_metadata),
                                {{"node", "test"},
                                 {"started_unix_ns", std::to_string(started_unix_ns)},
                                 {"started_clock", nlohmann::json(started_clock).dump()},
                                 {"ports", nlohmann::json::array({port_}).dump()},
                                 {"version", "1"}});
        const std::string decisions = layout::decisions_topic(port_);
        decisions_ =
            *writer_->add_channel(decisions, std::string(layout::record_encoding),
                                  {{std::string(layout::kind_key), std::string(layout::decisions_kind)},
                                   {std::string(layout::port_key), port_}});
    }

    void connection(const std::string& source, const std::string& carrier, std::uint64_t order) {
        channels_[source] =
            *writer_->add_channel(port_, std::string(layout::message_encoding),
                                  {{std::string(layout::kind_key), std::string(layout::messages_kind)},
                                   {std::string(layout::port_key), port_},
                                   {std::string(layout::source_key), source},
                                   {std::string(layout::carrier_key), carrier},
                                   {std::string(layout::order_key), std::to_string(order)}});
    }
    /// A message that arrived at `clock` seconds on the arbitration clock.
    void message(const std::string& source, std::uint64_t seq, double clock, const proto::Bytes& payload) {
        const auto log_time = unix_ns(clock);
        ASSERT_TRUE(writer_->write_message(channels_.at(source), static_cast<std::uint32_t>(seq), log_time,
                                           log_time - 1000, payload));
    }
    void decision(const std::string& source, std::uint64_t seq, const std::string& outcome,
                  double monitor_time, double decision_time) {
        const std::string text = nlohmann::json{
            {"source", source},
            {"seq", seq},
            {"outcome", outcome},
            {"monitor_time", monitor_time},
            {"decision_time",
             decision_time}}.dump();
        const auto at = unix_ns(decision_time != 0 ? decision_time : started_clock);
        ASSERT_TRUE(writer_->write_message(decisions_, 0, at, at, proto::as_bytes(text)));
    }
    void close() {
        writer_->write_metadata(std::string(layout::end_metadata), {{"reason", "test"}});
        ASSERT_TRUE(writer_->close());
    }

    static std::uint64_t unix_ns(double clock) {
        return started_unix_ns + static_cast<std::uint64_t>((clock - started_clock) * 1e9 + 0.5);
    }

private:
    std::string port_;
    std::unique_ptr<mcap::Writer> writer_;
    std::map<std::string, std::uint16_t> channels_;
    std::uint16_t decisions_ = 0;
};

/// The daemon's side of a recording: what the monitors' host says the time is.
class LiveHost final : public monitor::MonitorHost {
public:
    explicit LiveHost(const arbitration::ManualClock& clock) : clock_(clock) {}
    proto::Status publish(monitor::Monitor&, const std::string&, const nlohmann::json&) override {
        return proto::Ok{};
    }
    void set_trig_interval(monitor::Monitor&, double) override {}
    double now() const override {
        return static_cast<double>(started_unix_ns) / 1e9 + (clock_.now() - started_clock);
    }
    void monitor_gone(monitor::Monitor&) override {}

private:
    const arbitration::ManualClock& clock_;
};

/// A port run live by the test, as the daemon runs it: monitors, then the arbitration.
class LivePort {
public:
    struct Connection {
        std::string source;
        std::string carrier;
    };
    LivePort(const std::string& port, const std::vector<Connection>& connections,
             const std::string& script_dir)
        : host_(clock_), arbiter_(std::make_shared<arbitration::Arbiter>(clock_)) {
        clock_.set(started_clock);
        policy_.limits.budget = std::chrono::milliseconds(200);
        const std::vector<std::string> scripts{script_dir};
        const std::vector<std::string> libs;
        const monitor::ChainPlaces places{scripts, libs, policy_};
        for (const auto& connection : connections) {
            auto carrier = proto::parse_carrier(connection.carrier);
            EXPECT_TRUE(carrier.ok());
            auto member = std::make_shared<arbitration::Member>(arbiter_, connection.source);
            EXPECT_TRUE(arbitration::configure_member(*member, *carrier).ok());
            auto chain = monitor::build_carrier_chain(*carrier, proto::Side::recv, connection.source, port,
                                                      member, places, host_);
            EXPECT_TRUE(chain.ok()) << (chain.ok() ? "" : chain.error().message);
            arbiter_->join(*member);
            members_[connection.source] = {member, chain.ok() ? *chain : nullptr};
        }
    }
    ~LivePort() {
        for (auto& [source, entry] : members_)
            entry.second.reset();
    }

    /// The outcome of one message from `source`: monitors at `monitor_time`, arbitration at `decision_time`.
    std::string decide(const std::string& source, std::uint64_t seq, const proto::Bytes& payload,
                       double monitor_time, double decision_time) {
        auto& [member, chain] = members_.at(source);
        clock_.set(monitor_time);
        if (chain) {
            proto::Bytes bytes;
            proto::append_record(bytes, source, seq, RecordingWriter::unix_ns(monitor_time) - 1000, payload);
            auto storage = std::make_shared<daemon::Chunk>(bytes.size());
            std::copy(bytes.begin(), bytes.end(), storage->data());
            daemon::Message message{storage, proto::ByteView(storage->data(), bytes.size()), seq};
            if (!chain->process(message))
                return "accept";
        }
        clock_.set(decision_time);
        if (member->trivial())
            return "delivered";
        switch (arbiter_->admit(*member, decision_time)) {
            case arbitration::Arbiter::Verdict::deliver:
                return "delivered";
            case arbitration::Arbiter::Verdict::constraint:
                return "constraint";
            case arbitration::Arbiter::Verdict::priority:
                return "priority";
            case arbitration::Arbiter::Verdict::auxiliary:
                return "auxiliary";
        }
        return "?";
    }

private:
    arbitration::ManualClock clock_;
    LiveHost host_;
    monitor::MonitorPolicy policy_;
    std::shared_ptr<arbitration::Arbiter> arbiter_;
    std::map<std::string,
             std::pair<std::shared_ptr<arbitration::Member>, std::shared_ptr<monitor::MonitorChain>>>
        members_;
};

}  // namespace plexus::record::test
