// Calls (request/reply) at the frame level, through a real daemon: the answer goes back to the
// caller with the caller's id; every way a call can end without the server's answer ends in an
// answer from the daemon; answers that are not owed are counted and ignored. Raw peers, so that
// the daemon is tested without libplexus (tests/integration/calls_test.cpp uses the library).
#include <filesystem>
#include <fstream>

#include "hostile_peer.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::test::hostile {
namespace calls_test {

using proto::CallOutcome;

/// A raw client on the daemon's Unix socket that opens ports and sends and answers calls.
class RawClient {
public:
    explicit RawClient(const Daemon& daemon) : stream_(Stream::unix_socket(daemon.socket())) {
        EXPECT_TRUE(stream_.send(hello_frame("client")));
    }

    /// Opens `port` (to serve it when `serve`); its handle.
    std::uint64_t open(const std::string& port, bool serve = false,
                       std::optional<std::uint64_t> capacity = std::nullopt) {
        nlohmann::json body{{"op", "open"}, {"port", port}};
        if (serve)
            body["serve"] = true;
        if (capacity)
            body["capacity"] = *capacity;
        const auto reply = request(body);
        EXPECT_EQ(reply.code, proto::ReplyCode::ok) << reply.body.dump();
        return reply.body.value("handle", std::uint64_t{0});
    }
    proto::Reply request(const nlohmann::json& body) {
        const std::uint64_t id = next_request_++;
        EXPECT_TRUE(stream_.send(request_frame(id, body)));
        auto reply = reply_to(id);
        EXPECT_TRUE(reply.has_value()) << "no reply to " << body.dump();
        return reply.value_or(proto::Reply{});
    }
    void call(std::uint64_t handle, std::uint64_t id, const std::string& source, const nlohmann::json& value,
              std::uint64_t timeout_ms) {
        Bytes record;
        proto::append_record(record, source, id, 1, cbor(value));
        Bytes frame;
        proto::append_call_frame(frame, handle, id, timeout_ms, record);
        EXPECT_TRUE(stream_.send(frame));
    }
    void answer(std::uint64_t id, const std::string& source, const nlohmann::json& value) {
        Bytes record;
        proto::append_record(record, source, 1, 1, cbor(value));
        Bytes frame;
        proto::append_answer_frame(frame, id, record);
        EXPECT_TRUE(stream_.send(frame));
    }
    void send(const Bytes& bytes) { EXPECT_TRUE(stream_.send(bytes)); }

    struct Call {
        std::uint64_t handle;
        std::uint64_t id;
        std::uint64_t timeout_ms;
        nlohmann::json value;
        std::string source;
    };
    /// The next call frame delivered to this client.
    std::optional<Call> next_call(std::chrono::milliseconds wait = exchange_timeout) {
        const auto frame = next_of(proto::FrameType::call, wait);
        if (!frame)
            return std::nullopt;
        const auto call = proto::decode_call(frame->fields);
        EXPECT_TRUE(call.ok());
        const auto record = proto::decode_record(call->record);
        EXPECT_TRUE(record.ok());
        return Call{call->handle, call->id, call->timeout_ms,
                    nlohmann::json::from_cbor(record->payload.begin(), record->payload.end()),
                    std::string(record->source)};
    }
    struct Answer {
        std::uint64_t id;
        CallOutcome outcome;
        nlohmann::json value;
        std::string reason;
    };
    std::optional<Answer> next_answer(std::chrono::milliseconds wait = exchange_timeout) {
        const auto frame = next_of(proto::FrameType::answer, wait);
        if (!frame)
            return std::nullopt;
        const auto answer = proto::decode_answer(frame->fields);
        EXPECT_TRUE(answer.ok());
        Answer out{answer->id, answer->outcome, nullptr, std::string(answer->reason)};
        if (answer->outcome == CallOutcome::ok) {
            const auto record = proto::decode_record(answer->record);
            EXPECT_TRUE(record.ok());
            out.value = nlohmann::json::from_cbor(record->payload.begin(), record->payload.end());
        }
        return out;
    }
    Stream& stream() { return stream_; }

private:
    std::optional<proto::Reply> reply_to(std::uint64_t id) {
        const auto frame = next_matching(
            [id](const Frame& frame) {
                const auto reply = proto::decode_reply(frame.fields);
                return frame.type == proto::FrameType::reply && reply && reply->id == id;
            },
            exchange_timeout);
        return frame ? std::optional(*proto::decode_reply(frame->fields)) : std::nullopt;
    }
    std::optional<Frame> next_of(proto::FrameType type, std::chrono::milliseconds wait) {
        return next_matching([type](const Frame& frame) { return frame.type == type; }, wait);
    }
    /// The first frame `match` takes, from those kept or read now (the others are kept).
    std::optional<Frame> next_matching(const std::function<bool(const Frame&)>& match,
                                       std::chrono::milliseconds wait) {
        const auto deadline = Clock::now() + wait;
        for (;;) {
            for (auto it = kept_.begin(); it != kept_.end(); ++it) {
                if (match(*it)) {
                    Frame frame = std::move(*it);
                    kept_.erase(it);
                    return frame;
                }
            }
            auto frame = stream_.next_frame(deadline);
            if (!frame)
                return std::nullopt;
            kept_.push_back(std::move(*frame));
        }
    }

    Stream stream_;
    std::uint64_t next_request_ = 1;
    std::vector<Frame> kept_;  ///< frames read while looking for another kind
};

nlohmann::json daemon_stats(RawClient& client) {
    const auto reply = client.request({{"op", "stats"}});
    EXPECT_EQ(reply.code, proto::ReplyCode::ok) << reply.body.dump();
    return reply.body.value("daemon", nlohmann::json::object());
}

void connect(RawClient& client, const std::string& source, const std::string& destination,
             const std::string& carrier = "") {
    nlohmann::json body{{"op", "connect"}, {"source", source}, {"destination", destination}};
    if (!carrier.empty())
        body["carrier"] = carrier;
    const auto reply = client.request(body);
    ASSERT_EQ(reply.code, proto::ReplyCode::ok) << reply.body.dump();
}

TEST(Calls_test, AnAnswerGoesBackWithTheCallersIdAndAnswersNotOwedAreCountedAndIgnored) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient server(daemon);
    RawClient caller(daemon);
    const auto served = server.open("/svc", true);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc");

    caller.call(calling, 77, "/caller", {{"x", 1}}, 5000);
    const auto call = server.next_call();
    ASSERT_TRUE(call.has_value()) << "the call never reached the server";
    EXPECT_EQ(call->handle, served);
    EXPECT_EQ(call->source, "/caller");
    EXPECT_EQ(call->value, (nlohmann::json{{"x", 1}}));
    EXPECT_GT(call->timeout_ms, 0u);
    EXPECT_LE(call->timeout_ms, 5000u);
    server.answer(call->id, "/svc", {{"y", 2}});
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value()) << "no answer came back";
    EXPECT_EQ(answer->id, 77u);
    EXPECT_EQ(answer->outcome, CallOutcome::ok) << answer->reason;
    EXPECT_EQ(answer->value, (nlohmann::json{{"y", 2}}));

    server.answer(call->id, "/svc", "again");  // a duplicate
    server.answer(call->id + 1000, "/svc", "never asked");
    caller.answer(call->id, "/caller", "not mine to answer");  // a caller answering a call it sent
    EXPECT_FALSE(caller.next_answer(std::chrono::milliseconds(200)).has_value());
    RawClient observer(daemon);  // a stream that timed out once reads no more (Stream::next_frame)
    const auto stats = daemon_stats(observer);
    EXPECT_EQ(stats.value("calls_answered", 0), 1) << stats.dump();
    EXPECT_EQ(stats.value("calls_duplicate_answers", 0), 1) << stats.dump();
    EXPECT_EQ(stats.value("calls_unknown_answers", 0), 2) << stats.dump();
    EXPECT_EQ(stats.value("calls_outstanding", -1), 0) << stats.dump();
}

TEST(Calls_test, ACallWithNowhereToGoIsRefusedAtOnceWithTheReason) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient plain(daemon);
    RawClient caller(daemon);
    plain.open("/plain");
    const auto lonely = caller.open("/lonely");
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/plain");

    const auto started = Clock::now();
    caller.call(lonely, 1, "/lonely", 1, 10000);
    auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::refused);
    EXPECT_NE(answer->reason.find("has no connection to a server"), std::string::npos) << answer->reason;

    caller.call(calling, 2, "/caller", 2, 10000);
    answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->id, 2u);
    EXPECT_EQ(answer->outcome, CallOutcome::refused);
    EXPECT_NE(answer->reason.find("/plain is not served"), std::string::npos) << answer->reason;

    caller.call(99, 3, "/caller", 3, 10000);  // a handle that is not open
    answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::refused);
    EXPECT_NE(answer->reason.find("no open port with handle 99"), std::string::npos) << answer->reason;
    EXPECT_LT(Clock::now() - started, std::chrono::seconds(5)) << "refusals must not wait for the timeout";

    const auto stats = daemon_stats(caller);
    EXPECT_FALSE(plain.next_call(std::chrono::milliseconds(100)).has_value());
    EXPECT_EQ(stats.value("calls_refused", 0), 3) << stats.dump();
}

TEST(Calls_test, ADatagramCarrierCarriesNoCalls) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient server(daemon);
    RawClient caller(daemon);
    server.open("/svc", true);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc", "udp");
    caller.call(calling, 5, "/caller", 1, 10000);
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::refused);
    EXPECT_NE(answer->reason.find("udp, a datagram carrier"), std::string::npos) << answer->reason;
}

TEST(Calls_test, NoAnswerByTheDeadlineIsATimeoutAndTheLateAnswerIsCounted) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient server(daemon);
    RawClient caller(daemon);
    server.open("/svc", true);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc");

    const auto started = Clock::now();
    caller.call(calling, 9, "/caller", "slow", 300);
    const auto call = server.next_call();
    ASSERT_TRUE(call.has_value());
    const auto answer = caller.next_answer();
    const auto waited = Clock::now() - started;
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::timeout) << answer->reason;
    EXPECT_GE(waited, std::chrono::milliseconds(300));
    server.answer(call->id, "/svc", "too late");
    EXPECT_FALSE(caller.next_answer(std::chrono::milliseconds(200)).has_value());
    RawClient observer(daemon);
    const auto stats = daemon_stats(observer);
    EXPECT_EQ(stats.value("calls_timed_out", 0), 1) << stats.dump();
    EXPECT_EQ(stats.value("calls_late_answers", 0), 1) << stats.dump();
}

TEST(Calls_test, AServerThatGoesAwayWithACallIsALossAtOnce) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient caller(daemon);
    const auto calling = caller.open("/caller");
    {
        RawClient server(daemon);
        server.open("/svc", true);
        connect(caller, "/caller", "/svc");
        caller.call(calling, 4, "/caller", "hello", 30000);
        ASSERT_TRUE(server.next_call().has_value());
        const auto started = Clock::now();
        server.stream().close();
        const auto answer = caller.next_answer();
        ASSERT_TRUE(answer.has_value());
        EXPECT_EQ(answer->outcome, CallOutcome::lost) << answer->reason;
        EXPECT_NE(answer->reason.find("went away"), std::string::npos) << answer->reason;
        EXPECT_LT(Clock::now() - started, std::chrono::seconds(5));
    }
    const auto stats = daemon_stats(caller);
    EXPECT_EQ(stats.value("calls_lost", 0), 1) << stats.dump();
}

TEST(Calls_test, AnAnswerForACallerThatLeftIsCounted) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient server(daemon);
    server.open("/svc", true);
    std::optional<RawClient::Call> call;
    {
        RawClient caller(daemon);
        const auto calling = caller.open("/caller");
        connect(caller, "/caller", "/svc");
        caller.call(calling, 1, "/caller", "bye", 30000);
        call = server.next_call();
        ASSERT_TRUE(call.has_value());
    }
    // The caller's session may take a moment to close: its answer then finds nobody.
    RawClient observer(daemon);
    ASSERT_TRUE(eventually([&] {
        server.answer(call->id, "/svc", "anyone?");
        const auto stats = daemon_stats(observer);
        return stats.value("calls_caller_gone", 0) + stats.value("calls_duplicate_answers", 0) >= 1 &&
               stats.value("calls_caller_gone", 0) == 1;
    }));
}

TEST(Calls_test, APortTakesAtMostItsLimitOfOutstandingCalls) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    RawClient server(daemon);
    RawClient caller(daemon);
    constexpr std::uint64_t limit = 4096;
    // The server reads nothing: its queue must hold every call the limit lets through, or the
    // queue (not the limit) refuses them once the socket's buffer is full — how much that buffer
    // holds differs between machines.
    server.open("/svc", true, 2 * limit);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc");
    for (std::uint64_t id = 1; id <= limit + 1; ++id)
        caller.call(calling, id, "/caller", id, 60000);
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->id, limit + 1);
    EXPECT_EQ(answer->outcome, CallOutcome::refused);
    EXPECT_NE(answer->reason.find("busy"), std::string::npos) << answer->reason;
    const auto stats = daemon_stats(caller);
    EXPECT_EQ(stats.value("calls_outstanding", 0), static_cast<int>(limit)) << stats.dump();
    EXPECT_EQ(stats.value("calls_busy", 0), 1) << stats.dump();
}

TEST(Calls_test, AcrossDaemonsTheAnswerComesBackAlongTheLink) {
    TempDir dir;
    Daemon first(dir, "first");
    TempDir other_dir;
    Daemon second(other_dir, "second", first.names());
    RawClient server(second);
    RawClient caller(first);
    server.open("/svc", true);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc", "tcp");

    for (std::uint64_t id = 1; id <= 3; ++id) {
        caller.call(calling, id, "/caller", {{"n", id}}, 5000);
        const auto call = server.next_call();
        ASSERT_TRUE(call.has_value()) << "call " << id << " never reached the other daemon";
        EXPECT_EQ(call->value, (nlohmann::json{{"n", id}}));
        server.answer(call->id, "/svc", {{"twice", 2 * id}});
        const auto answer = caller.next_answer();
        ASSERT_TRUE(answer.has_value());
        EXPECT_EQ(answer->id, id);
        EXPECT_EQ(answer->outcome, CallOutcome::ok) << answer->reason;
        EXPECT_EQ(answer->value, (nlohmann::json{{"twice", 2 * id}}));
    }
    // The server goes with a call: its daemon tells the caller's, which tells the caller.
    caller.call(calling, 4, "/caller", "last", 30000);
    ASSERT_TRUE(server.next_call().has_value());
    const auto started = Clock::now();
    server.stream().close();
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->id, 4u);
    EXPECT_EQ(answer->outcome, CallOutcome::lost) << answer->reason;
    EXPECT_LT(Clock::now() - started, std::chrono::seconds(5));
}

TEST(Calls_test, WhenTheServersDaemonIsKilledTheCallIsLostAtOnce) {
    TempDir dir;
    Daemon first(dir, "first");
    TempDir other_dir;
    Daemon second(other_dir, "second", first.names());
    RawClient server(second);
    RawClient caller(first);
    server.open("/svc", true);
    const auto calling = caller.open("/caller");
    connect(caller, "/caller", "/svc", "tcp");
    caller.call(calling, 1, "/caller", "doomed", 30000);
    ASSERT_TRUE(server.next_call().has_value());
    const auto started = Clock::now();
    second.process().signal(SIGKILL);
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::lost) << answer->reason;
    EXPECT_LT(Clock::now() - started, std::chrono::seconds(5));
}

TEST(Calls_test, MonitorsSeeTheRequestWithUpdateAndTheAnswerWithReply) {
    TempDir dir;
    const std::string scripts = dir.file("scripts");
    std::filesystem::create_directories(scripts);
    {
        std::ofstream script(scripts + "/stamp.lua");
        script << "PortMonitor = PortMonitor or {}\n"
                  "function PortMonitor.update(msg) return {request = msg.data} end\n"
                  "function PortMonitor.reply(msg) return {reply = msg.data, stamped = true} end\n";
    }
    {
        std::ofstream script(scripts + "/refuse.lua");
        script << "PortMonitor = PortMonitor or {}\n"
                  "function PortMonitor.accept(msg) return msg.data ~= 'forbidden' end\n";
    }
    Daemon daemon(dir, "solo", "", {"--scripts", scripts});
    RawClient server(daemon);
    RawClient caller(daemon);
    server.open("/svc", true);
    server.open("/guarded", true);
    const auto calling = caller.open("/caller");
    const auto guarded = caller.open("/guard-caller");
    connect(caller, "/caller", "/svc", "local+recv.portmonitor+type.lua+file.stamp");
    connect(caller, "/guard-caller", "/guarded", "local+send.portmonitor+type.lua+file.refuse");

    caller.call(calling, 1, "/caller", 41, 5000);
    const auto call = server.next_call();
    ASSERT_TRUE(call.has_value());
    EXPECT_EQ(call->value, (nlohmann::json{{"request", 41}}));
    server.answer(call->id, "/svc", 42);
    const auto answer = caller.next_answer();
    ASSERT_TRUE(answer.has_value());
    EXPECT_EQ(answer->outcome, CallOutcome::ok) << answer->reason;
    EXPECT_EQ(answer->value, (nlohmann::json{{"reply", 42}, {"stamped", true}}));

    caller.call(guarded, 2, "/guard-caller", "forbidden", 5000);
    const auto refused = caller.next_answer();
    ASSERT_TRUE(refused.has_value());
    EXPECT_EQ(refused->id, 2u);
    EXPECT_EQ(refused->outcome, CallOutcome::refused);
    EXPECT_NE(refused->reason.find("dropped by a monitor's accept"), std::string::npos) << refused->reason;
}

TEST(Calls_test, APortNobodyServesPassesTheCallToTheServerItsEventsSelect) {
    TempDir dir;
    const std::string scripts = dir.file("scripts");
    std::filesystem::create_directories(scripts);
    {
        std::ofstream script(scripts + "/health.lua");
        script << "PortMonitor = PortMonitor or {}\n"
                  "function PortMonitor.accept(msg)\n"
                  "  if msg.data == 'a' then PortMonitor.setEvent('a_ok') else "
                  "PortMonitor.unsetEvent('a_ok') end\n"
                  "  return true\n"
                  "end\n";
    }
    Daemon daemon(dir, "solo", "", {"--scripts", scripts});
    RawClient server_a(daemon);
    RawClient server_b(daemon);
    RawClient service(daemon);
    RawClient health(daemon);
    RawClient caller(daemon);
    server_a.open("/a", true);
    server_b.open("/b", true);
    service.open("/nav/plan");
    const auto health_handle = health.open("/health");
    const auto calling = caller.open("/caller");
    connect(caller, "/health", "/nav/plan", "local+recv.portmonitor+type.lua+file.health+aux");
    connect(caller, "/nav/plan", "/a", "local+send.portmonitor+constraint.a_ok");
    connect(caller, "/nav/plan", "/b", "local+send.portmonitor+constraint.not a_ok");
    connect(caller, "/caller", "/nav/plan");

    std::uint64_t seq = 0;
    const auto say = [&](const std::string& state, bool a_ok) {
        Bytes record;
        proto::append_record(record, "/health", ++seq, 1, cbor(state));
        Bytes frame;
        proto::append_data_frame(frame, health_handle, record);
        health.send(frame);
        ASSERT_TRUE(eventually([&] {
            const auto events = caller.request({{"op", "events"}, {"port", "/nav/plan"}}).body.dump();
            return (events.find("a_ok") != std::string::npos) == a_ok;
        })) << "the monitor never took "
            << state;
    };
    const auto expect_served_by = [&](RawClient& server, std::uint64_t id) {
        caller.call(calling, id, "/caller", id, 5000);
        const auto call = server.next_call();
        ASSERT_TRUE(call.has_value()) << "call " << id << " did not reach the server the events select";
        server.answer(call->id, "/x", id * 10);
        const auto answer = caller.next_answer();
        ASSERT_TRUE(answer.has_value());
        EXPECT_EQ(answer->id, id);
        EXPECT_EQ(answer->value, id * 10) << answer->reason;
    };
    say("a", true);
    expect_served_by(server_a, 1);
    expect_served_by(server_a, 2);
    say("b", false);
    expect_served_by(server_b, 3);
    say("a", true);
    expect_served_by(server_a, 4);
}

TEST(Calls_test, AMalformedCallOrAnswerIsAProtocolError) {
    TempDir dir;
    Daemon daemon(dir, "solo");
    const long rss_before = daemon.rss_kib();
    const std::vector<std::pair<std::string, Bytes>> bad{
        {"a cut call", Bytes{0x02, static_cast<std::uint8_t>(proto::FrameType::call), 0x01}},
        {"a call past the longest timeout",
         [] {
             Bytes frame;
             proto::append_call_frame(frame, 1, 1, proto::max_call_timeout_ms + 1, {});
             return frame;
         }()},
        {"an answer of an unknown outcome",
         Bytes{0x03, static_cast<std::uint8_t>(proto::FrameType::answer), 0x01, 0x09}},
        {"an answer whose reply is not a record",
         [] {
             Bytes frame;
             proto::append_answer_frame(frame, 1, Bytes{0xff, 0xff});
             return frame;
         }()},
        {"a call whose record is not one",
         [] {
             Bytes frame;
             proto::append_call_frame(frame, 1, 1, 100, Bytes{0xff, 0xff});
             return frame;
         }()},
    };
    int n = 0;
    for (const auto& [what, frame] : bad) {
        SCOPED_TRACE(what);
        RawClient client(daemon);
        client.open("/p" + std::to_string(n++));  // handle 1: the frames name it
        client.send(frame);
        const auto frames = client.stream().frames_until_closed();
        EXPECT_TRUE(error_reason(frames).has_value()) << "no error frame";
    }
    expect_unharmed(daemon, rss_before);
}

}  // namespace calls_test
}  // namespace plexus::test::hostile
