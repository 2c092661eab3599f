#pragma once
// What the hostile tests of the shared-memory rings share (rings_test.cpp, rings_wake_test.cpp):
// a well-behaved libplexus client that must keep working beside every attack, the daemon's
// counters as `plexus stats --json` shows them, and the expectations every attack ends with.
#include "ring_peer.hpp"

namespace plexus::test::hostile {

/// A well-behaved libplexus client (on rings itself, the default) with two ports of its own,
/// connected: each round trip writes a fresh number and waits for it to come back.
class GoodClient {
public:
    explicit GoodClient(const Daemon& daemon)
        : client_(Client::Options{daemon.socket()}),
          out_(client_.open("/good/out")),
          in_(client_.open("/good/in")) {
        client_.connect(out_.name(), in_.name());
    }
    /// True when a message written now is read back within the exchange timeout.
    bool round_trip() {
        const int number = ++sent_;
        out_.write(Value{{"n", number}});
        const auto deadline = Clock::now() + exchange_timeout;
        while (Clock::now() < deadline) {
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
            const auto message = in_.read(left);
            if (!message)
                return false;
            if (message->data.is_object() && message->data.value("n", -1) == number)
                return true;
        }
        return false;
    }
    Client& client() { return client_; }
    Port& in() { return in_; }

private:
    Client client_;
    Port out_;
    Port in_;
    int sent_ = 0;
};

/// The daemon's counters, as `plexus stats --json` shows them.
inline nlohmann::json daemon_counters(const TempDir& dir, const Daemon& daemon) {
    const auto result = run_cli(dir, daemon, {"stats", "--json"});
    EXPECT_EQ(result.status, 0) << result.err;
    const auto stats = nlohmann::json::parse(result.out, nullptr, false);
    if (stats.is_discarded() || !stats.contains("daemon")) {
        ADD_FAILURE() << "plexus stats --json gave no daemon counters: " << result.out;
        return nlohmann::json::object();
    }
    return stats["daemon"];
}

inline std::uint64_t counter(const nlohmann::json& counters, const std::string& name) {
    return counters.value(name, std::uint64_t{0});
}

/// What every attack ends with: the daemon runs; the good client, a fresh socket peer and a
/// fresh ring peer are served; `plexus stats` counts at least `protocol_errors` peers cut off for
/// breaking the protocol and at least `ring_sessions` sessions moved to rings.
inline void expect_others_served(const TempDir& dir, Daemon& daemon, GoodClient& good,
                                 std::uint64_t protocol_errors, std::uint64_t ring_sessions) {
    EXPECT_TRUE(daemon.process().running()) << "the daemon died";
    EXPECT_TRUE(good.round_trip()) << "the good client's message did not come back in time";
    EXPECT_TRUE(still_answers(daemon, Listener::daemon_unix)) << "a socket client is not answered";
    RingPeer fresh(daemon);
    if (fresh.start()) {
        EXPECT_TRUE(fresh.send(request_frame(9, {{"op", "node"}})));
        const auto reply = fresh.reply_to(9);
        EXPECT_TRUE(reply && reply->code == proto::ReplyCode::ok) << "a fresh ring client is not answered";
    }
    const auto counters = daemon_counters(dir, daemon);
    EXPECT_GE(counter(counters, "protocol_errors"), protocol_errors) << counters.dump();
    EXPECT_GE(counter(counters, "ring_sessions"), ring_sessions) << counters.dump();
}

/// Opens `port` through the rings (`options` added to the request): its handle, or nullopt and
/// a test failure.
inline std::optional<std::uint64_t> open_through_rings(RingPeer& peer, std::uint64_t id,
                                                       const std::string& port,
                                                       nlohmann::json options = nlohmann::json::object()) {
    options["op"] = "open";
    options["port"] = port;
    if (!peer.send(request_frame(id, options))) {
        ADD_FAILURE() << "could not write the open request into the ring";
        return std::nullopt;
    }
    const auto opened = peer.reply_to(id);
    if (!opened || opened->code != proto::ReplyCode::ok) {
        ADD_FAILURE() << "open " << port << " failed: " << (opened ? opened->body.dump() : "no reply");
        return std::nullopt;
    }
    return opened->body["handle"].get<std::uint64_t>();
}

/// The records a data or data_batch frame carries for its handle.
inline std::vector<std::pair<std::uint64_t, Bytes>> records_of(const Frame& frame) {
    std::vector<std::pair<std::uint64_t, Bytes>> out;
    if (frame.type == FrameType::data) {
        const auto data = proto::decode_data(frame.fields);
        if (data)
            out.emplace_back(data->handle, Bytes(data->record.begin(), data->record.end()));
    } else if (frame.type == FrameType::data_batch) {
        const auto batch = proto::decode_batch(frame.fields);
        if (batch) {
            proto::BatchRecords records(batch->records, batch->count);
            while (const auto record = records.next())
                out.emplace_back(batch->handle, Bytes(record->begin(), record->end()));
        }
    }
    return out;
}

/// What the peer sees after an attack: the session ends (the socket closes) within the deadline,
/// after an error frame through the ring naming `reason` if one is given; then the peer closes.
inline void expect_cut_off(RingPeer& peer, const std::string& reason) {
    const auto frames = peer.frames_until_closed();
    EXPECT_EQ(peer.wait_for_socket_end(), End::eof) << "session " << end_name(peer.socket_end());
    peer.close_socket();  // as a client seeing the end does
    if (reason.empty())
        return;
    const auto said = error_reason(frames);
    ASSERT_TRUE(said.has_value()) << "no error frame through the ring (" << frames.size() << " frames)";
    EXPECT_NE(said->find(reason), std::string::npos) << "reason '" << *said << "' lacks '" << reason << "'";
}

}  // namespace plexus::test::hostile
