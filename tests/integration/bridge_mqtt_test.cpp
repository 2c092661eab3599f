// plexus-bridge mqtt against a real Debian mosquitto broker that each test starts on a free port:
// MQTT -> Plexus through a pattern, Plexus -> MQTT, retained messages both ways, no loop between
// an --in and an --out joined by a Plexus connection, a broker restart, counters of what could not
// be converted, and a broker that wants a password (docs/BRIDGES-mqtt.md).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace bridge_mqtt_test {

using nlohmann::json;

/// A port free now on 127.0.0.1 (bound to 0, read back, closed): the broker may lose it to another
/// program before it binds, so Broker retries with another.
int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
    socklen_t length = sizeof address;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
    ::close(fd);
    return ntohs(address.sin_port);
}

int count_of(const std::string& text, const std::string& part) {
    int count = 0;
    for (auto at = text.find(part); at != std::string::npos; at = text.find(part, at + 1))
        ++count;
    return count;
}

/// Debian's mosquitto with a config of the test's: `listener PORT 127.0.0.1` then `extra` lines.
class Broker {
public:
    Broker(const TempDir& dir, std::string name, std::string extra = "allow_anonymous true\n")
        : dir_(dir), name_(std::move(name)), extra_(std::move(extra)) {
        for (int attempt = 0; attempt < 10 && !process_; ++attempt) {
            port_ = free_port();
            if (!launch())
                process_.reset();
        }
        if (!process_)
            throw std::runtime_error("mosquitto did not start: " + last_log_);
    }
    int port() const { return port_; }
    std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
    std::string log() const { return process_ ? process_->out() + process_->err() : last_log_; }
    /// Kills the broker as a crash would (SIGKILL).
    void kill() {
        process_->signal(SIGKILL);
        process_->wait();
        last_log_ = process_->out() + process_->err();
        process_.reset();
    }
    /// Starts it again on the same port (retrying while the port is still held).
    bool start_again() {
        return eventually([&] { return launch(); }, 10s);
    }

private:
    /// Starts mosquitto; true once it listens, false if it exited (the port was taken).
    bool launch() {
        const auto config = dir_.file(name_ + ".conf");
        // Started as root, mosquitto becomes user "mosquitto", who cannot read the test's files:
        // it stays who runs the test (the setting does nothing for anyone else).
        std::ofstream(config) << "listener " << port_ << " 127.0.0.1\nlog_dest stderr\nuser "
                              << ::getpwuid(::geteuid())->pw_name << "\n"
                              << extra_;
        process_ = std::make_unique<Process>(std::vector<std::string>{"/usr/sbin/mosquitto", "-c", config},
                                             std::map<std::string, std::string>{},
                                             dir_.file(name_ + "." + std::to_string(++starts_)));
        const std::string ready = "listen socket on port " + std::to_string(port_);
        eventually([&] { return log().find(ready) != std::string::npos || !process_->running(); });
        if (process_->running() && log().find(ready) != std::string::npos)
            return true;
        last_log_ = log();
        process_.reset();
        return false;
    }

    const TempDir& dir_;
    std::string name_;
    std::string extra_;
    int port_ = 0;
    int starts_ = 0;
    std::string last_log_;
    std::unique_ptr<Process> process_;
};

/// Runs a mosquitto client program (mosquitto_pub, ...) to its end; its exit status.
int run_tool(const TempDir& dir, const std::vector<std::string>& argv, const std::string& name) {
    Process tool(argv, {}, dir.file(name));
    const auto status = tool.wait(20s);
    EXPECT_EQ(status, 0) << name << ": " << tool.err();
    return status.value_or(-1);
}

/// mosquitto_pub of `message` on `topic`; with `-f FILE` in `extra`, `message` must be empty.
void publish(const TempDir& dir, const Broker& broker, const std::string& topic, const std::string& message,
             std::vector<std::string> extra = {}) {
    std::vector<std::string> argv{"/usr/bin/mosquitto_pub",
                                  "-p",
                                  std::to_string(broker.port()),
                                  "-h",
                                  "127.0.0.1",
                                  "-q",
                                  "1",
                                  "-t",
                                  topic};
    if (!message.empty())
        argv.insert(argv.end(), {"-m", message});
    argv.insert(argv.end(), extra.begin(), extra.end());
    run_tool(dir, argv, "pub");
}

/// A mosquitto_sub, started and waited for until the broker acknowledged its subscription.
class Subscriber {
public:
    Subscriber(const TempDir& dir, const Broker& broker, const std::string& topic, const std::string& name,
               std::vector<std::string> extra = {}) {
        // Line-buffered: mosquitto_sub's stdout is a file here, which stdio would fill in blocks.
        std::vector<std::string> argv{"/usr/bin/stdbuf",
                                      "-oL",
                                      "/usr/bin/mosquitto_sub",
                                      "-d",
                                      "-v",
                                      "-p",
                                      std::to_string(broker.port()),
                                      "-h",
                                      "127.0.0.1",
                                      "-t",
                                      topic};
        argv.insert(argv.end(), extra.begin(), extra.end());
        process_ = std::make_unique<Process>(argv, std::map<std::string, std::string>{}, dir.file(name));
        EXPECT_TRUE(eventually([&] { return process_->out().find("received SUBACK") != std::string::npos; }))
            << process_->out() << process_->err();
    }
    /// "TOPIC PAYLOAD" lines received so far (the debug lines left out).
    std::vector<std::string> messages() const {
        std::vector<std::string> lines;
        std::istringstream in(process_->out());
        for (std::string line; std::getline(in, line);) {
            if (!line.empty() && line.rfind("Client ", 0) != 0 && line.rfind("Subscribed ", 0) != 0)
                lines.push_back(line);
        }
        return lines;
    }
    Process& process() { return *process_; }

private:
    std::unique_ptr<Process> process_;
};

/// A plexus-bridge mqtt for `daemon` and `broker`; waited for until it subscribed (when it has
/// --in mappings) or connected.
std::unique_ptr<Process> start_bridge(const TempDir& dir, const Daemon& daemon, const Broker& broker,
                                      const std::vector<std::string>& mappings,
                                      const std::string& name = "bridge",
                                      std::map<std::string, std::string> env = {}, bool wait_ready = true) {
    std::vector<std::string> argv{PLEXUS_BRIDGE, "mqtt", "--broker", broker.address()};
    argv.insert(argv.end(), mappings.begin(), mappings.end());
    env.merge(daemon.env());
    auto bridge = std::make_unique<Process>(argv, env, dir.file(name));
    if (!wait_ready)
        return bridge;
    const bool subscribes = std::find(mappings.begin(), mappings.end(), "--in") != mappings.end();
    const std::string ready = subscribes ? "subscribed to" : "connected";
    EXPECT_TRUE(eventually([&] {
        return bridge->out().find(ready) != std::string::npos || !bridge->running();
    })) << bridge->out()
        << bridge->err();
    EXPECT_TRUE(bridge->running()) << bridge->out() << bridge->err();
    return bridge;
}

/// A reader of the test's own, connected from a bridge's port once that port exists.
struct Reader {
    Reader(const TempDir& dir, const Daemon& daemon, const std::string& from, const std::string& name)
        : client(Client::Options{daemon.socket()}), port(client.open(name)) {
        EXPECT_TRUE(wait_port(dir, daemon, from));
        client.connect(from, name);
    }
    std::optional<Value> next(std::chrono::milliseconds timeout = 10s) {
        auto message = port.read(slower(timeout));
        if (!message)
            return std::nullopt;
        return message->data;
    }
    Client client;
    Port port;
};

/// The counters the bridge reported for `port` (`plexus stats PORT --json`, "reported").
json reported(const TempDir& dir, const Daemon& daemon, const std::string& port) {
    const auto stats = port_stats(dir, daemon, port);
    if (stats.is_null() || !stats.contains("reported"))
        return json::object();
    return stats["reported"];
}

bool reported_equals(const TempDir& dir, const Daemon& daemon, const std::string& port,
                     const std::string& key, std::uint64_t value) {
    const auto counters = reported(dir, daemon, port);
    return counters.contains(key) && counters[key] == value;
}

TEST(BridgeMqtt_test, PatternMatchedMessagesReachTheirPortAndOthersDoNot) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge = start_bridge(dir, daemon, broker, {"--in", "sensors/+/temp=/mqtt/temp"});
    Reader reader(dir, daemon, "/mqtt/temp", "/test/reader");

    publish(dir, broker, "sensors/a/temp", R"({"c":21.5})");
    publish(dir, broker, "sensors/a/humidity", R"({"h":40})");
    publish(dir, broker, "sensors/b/temp", "warm");

    EXPECT_EQ(reader.next(), json::parse(R"({"c":21.5})"));
    EXPECT_EQ(reader.next(), json("warm"));  // not JSON but UTF-8 text: a string
    EXPECT_TRUE(eventually([&] { return reported_equals(dir, daemon, "/mqtt/temp", "passed", 2); }))
        << reported(dir, daemon, "/mqtt/temp");
}

TEST(BridgeMqtt_test, APlexusWriteIsPublishedOnTheMappedTopic) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge = start_bridge(dir, daemon, broker, {"--out", "/robot/state=robot/state"});
    Subscriber subscriber(dir, broker, "robot/state", "sub", {"-C", "1"});
    ASSERT_TRUE(wait_port(dir, daemon, "/robot/state"));

    const auto write = run_cli(dir, daemon, {"write", "/test/writer", "/robot/state"},
                               R"({"x":1})"
                               "\n");
    ASSERT_EQ(write.status, 0) << write.err;

    EXPECT_EQ(subscriber.process().wait(slower(std::chrono::milliseconds(10s))), 0)
        << subscriber.process().err();
    EXPECT_EQ(subscriber.messages(), std::vector<std::string>{R"(robot/state {"x":1})"});
}

TEST(BridgeMqtt_test, RetainedMessagesReachThePortAndRetainOnOutServesLateSubscribers) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    publish(dir, broker, "config/speed", "3", {"-r"});

    // No reader can be connected before the bridge opens its port, so the port's counter shows
    // the retained message arrived (nothing else is published on config/#).
    auto bridge =
        start_bridge(dir, daemon, broker,
                     {"--in", "config/#=/mqtt/config", "--out", "/robot/state=robot/state", "--retain"});
    EXPECT_TRUE(eventually([&] { return reported_equals(dir, daemon, "/mqtt/config", "passed", 1); }))
        << reported(dir, daemon, "/mqtt/config");

    ASSERT_EQ(run_cli(dir, daemon, {"write", "/test/writer", "/robot/state"}, "\"parked\"\n").status, 0);
    ASSERT_TRUE(eventually([&] { return reported_equals(dir, daemon, "/robot/state", "passed", 1); }));
    // Subscribed only now, after the publication: the broker kept it.
    Subscriber late(dir, broker, "robot/state", "late", {"-C", "1"});
    EXPECT_EQ(late.process().wait(slower(std::chrono::milliseconds(10s))), 0);
    EXPECT_EQ(late.messages(), std::vector<std::string>{R"(robot/state "parked")"});
}

TEST(BridgeMqtt_test, EnvelopeNamesTheTopicAndWhetherItWasRetained) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge = start_bridge(dir, daemon, broker, {"--in", "sensors/#=/mqtt/all", "--envelope"});
    Reader reader(dir, daemon, "/mqtt/all", "/test/reader");
    publish(dir, broker, "sensors/x/y", "[1,2]");
    EXPECT_EQ(reader.next(), json::parse(R"({"topic":"sensors/x/y","payload":[1,2],"retained":false})"));
}

TEST(BridgeMqtt_test, WhatTheBridgePublishesNeverComesBackInto) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge =
        start_bridge(dir, daemon, broker, {"--in", "loop/#=/mqtt/loop", "--out", "/mqtt/out=loop/x"});
    ASSERT_TRUE(wait_port(dir, daemon, "/mqtt/out"));
    ASSERT_EQ(run_cli(dir, daemon, {"connect", "/mqtt/loop", "/mqtt/out"}).status, 0);
    Subscriber watcher(dir, broker, "loop/#", "watcher");

    // From Plexus: published once on loop/x; MQTT's No Local keeps it from the bridge's loop/#.
    ASSERT_EQ(run_cli(dir, daemon, {"write", "/test/writer", "/mqtt/out"}, "\"first\"\n").status, 0);
    // From MQTT: into /mqtt/loop, then along the connection to /mqtt/out, where the bridge sees
    // its own message and does not publish it.
    publish(dir, broker, "loop/outside", "\"second\"");

    EXPECT_TRUE(eventually([&] { return reported_equals(dir, daemon, "/mqtt/out", "own_message", 1); }))
        << reported(dir, daemon, "/mqtt/out");
    // The bridge handles messages in order: had loop/x come back, /mqtt/loop would have passed it
    // before "second", and /mqtt/out would have dropped it as its own too.
    EXPECT_TRUE(eventually([&] {
        return reported(dir, daemon, "/mqtt/loop") == json{{"passed", 1}} &&
               reported(dir, daemon, "/mqtt/out") == json{{"passed", 1}, {"own_message", 1}};
    })) << reported(dir, daemon, "/mqtt/loop")
        << reported(dir, daemon, "/mqtt/out");
    EXPECT_TRUE(eventually([&] { return watcher.messages().size() == 2; })) << watcher.process().out();
    EXPECT_EQ(watcher.messages(),
              (std::vector<std::string>{R"(loop/x "first")", R"(loop/outside "second")"}));
}

TEST(BridgeMqtt_test, MessagesFlowBothWaysAgainAfterTheBrokerRestarts) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge =
        start_bridge(dir, daemon, broker,
                     {"--in", "sensors/+/temp=/mqtt/temp", "--out", "/robot/state=robot/state", "--retain"});
    Reader reader(dir, daemon, "/mqtt/temp", "/test/reader");
    publish(dir, broker, "sensors/a/temp", "1");
    ASSERT_EQ(reader.next(), json(1));

    broker.kill();
    ASSERT_TRUE(eventually([&] { return bridge->out().find("connection lost") != std::string::npos; }))
        << bridge->out();
    // Written while the broker is away: held, then published once it is back.
    ASSERT_EQ(run_cli(dir, daemon, {"write", "/test/writer", "/robot/state"}, "\"while away\"\n").status, 0);
    ASSERT_TRUE(broker.start_again()) << broker.log();
    EXPECT_TRUE(eventually([&] { return count_of(bridge->out(), "subscribed to") == 2; }, 20s))
        << bridge->out();

    publish(dir, broker, "sensors/a/temp", "2");
    EXPECT_EQ(reader.next(), json(2));
    Subscriber late(dir, broker, "robot/state", "late", {"-C", "1"});
    EXPECT_EQ(late.process().wait(slower(std::chrono::milliseconds(10s))), 0);
    EXPECT_EQ(late.messages(), std::vector<std::string>{R"(robot/state "while away")"});
    EXPECT_TRUE(bridge->running());
}

TEST(BridgeMqtt_test, WhatCannotBeConvertedIsCountedOnItsPort) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    Broker broker(dir, "broker");
    auto bridge = start_bridge(dir, daemon, broker,
                               {"--in", "sensors/+/temp=/mqtt/temp", "--out", "/robot/state=robot/state"});
    const auto bad = dir.file("bad.bin");
    std::ofstream(bad, std::ios::binary) << "\xff\xfe not UTF-8";
    publish(dir, broker, "sensors/a/temp", "", {"-f", bad});
    publish(dir, broker, "sensors/a/temp", "{\"ok\":true}");

    // A blob inside a map has no JSON text.
    Client client(Client::Options{daemon.socket()});
    auto writer = client.open("/test/writer");
    ASSERT_TRUE(wait_port(dir, daemon, "/robot/state"));
    client.connect("/test/writer", "/robot/state");
    writer.write(Value{{"image", Value::binary({1, 2, 3})}});

    EXPECT_TRUE(eventually([&] {
        return reported(dir, daemon, "/mqtt/temp") == json{{"passed", 1}, {"not_converted", 1}};
    })) << reported(dir, daemon, "/mqtt/temp");
    EXPECT_TRUE(eventually([&] {
        return reported(dir, daemon, "/robot/state") == json{{"passed", 0}, {"not_converted", 1}};
    })) << reported(dir, daemon, "/robot/state");
    // Logged once per reason, with the topic.
    EXPECT_EQ(count_of(bridge->out(), "(not_converted)"), 2) << bridge->out();
    EXPECT_NE(bridge->out().find("on topic sensors/a/temp"), std::string::npos);
}

TEST(BridgeMqtt_test, AWrongPasswordIsLoggedAndRetriedAndTheRightOneConnects) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    const auto passwords = dir.file("passwords");
    run_tool(dir, {"/usr/bin/mosquitto_passwd", "-b", "-c", passwords, "robot", "s3cret"}, "passwd");
    Broker broker(dir, "broker", "allow_anonymous false\npassword_file " + passwords + "\n");

    auto wrong = start_bridge(dir, daemon, broker, {"--in", "a/#=/mqtt/wrong", "--username", "robot"},
                              "wrong", {{"MQTT_PASSWORD", "guess"}}, false);
    EXPECT_TRUE(eventually([&] { return wrong->out().find("refused: ") != std::string::npos; }))
        << wrong->out();
    // The broker saw it come back after the refusal, and it is still running.
    EXPECT_TRUE(eventually([&] { return count_of(broker.log(), "not authorised") >= 3; }, 20s))
        << broker.log();
    EXPECT_TRUE(wrong->running()) << wrong->err();
    EXPECT_EQ(count_of(wrong->out(), "refused: "), 1) << "logged once, not every retry:\n" << wrong->out();

    auto right = start_bridge(dir, daemon, broker, {"--in", "a/#=/mqtt/right", "--username", "robot"},
                              "right", {{"MQTT_PASSWORD", "s3cret"}});
    Reader reader(dir, daemon, "/mqtt/right", "/test/reader");
    run_tool(dir,
             {"/usr/bin/mosquitto_pub", "-p", std::to_string(broker.port()), "-h", "127.0.0.1", "-u", "robot",
              "-P", "s3cret", "-t", "a/b", "-m", "7"},
             "pub");
    EXPECT_EQ(reader.next(), json(7));
}

/// A CA and a server certificate for 127.0.0.1 and localhost, made by openssl in `dir`.
void make_certificates(const TempDir& dir, const std::string& ca) {
    const auto openssl = [&](std::vector<std::string> args) {
        args.insert(args.begin(), "/usr/bin/openssl");
        run_tool(dir, args, "openssl");
    };
    openssl({"req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", dir.file(ca + ".key"), "-out",
             dir.file(ca + ".crt"), "-days", "2", "-subj", "/CN=" + ca});
    openssl({"req", "-newkey", "rsa:2048", "-nodes", "-keyout", dir.file("server.key"), "-out",
             dir.file("server.csr"), "-subj", "/CN=localhost"});
    std::ofstream(dir.file("server.ext")) << "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
    openssl({"x509", "-req", "-in", dir.file("server.csr"), "-CA", dir.file(ca + ".crt"), "-CAkey",
             dir.file(ca + ".key"), "-CAcreateserial", "-out", dir.file("server.crt"), "-days", "2",
             "-extfile", dir.file("server.ext")});
}

TEST(BridgeMqtt_test, TlsWithTheBrokersCaConnectsAndAnotherCaIsRefusedAndRetried) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    make_certificates(dir, "ca");
    // A CA that did not sign the broker's certificate.
    run_tool(dir,
             {"/usr/bin/openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout",
              dir.file("other.key"), "-out", dir.file("other.crt"), "-days", "2", "-subj", "/CN=other"},
             "openssl");
    Broker broker(dir, "broker",
                  "cafile " + dir.file("ca.crt") + "\ncertfile " + dir.file("server.crt") + "\nkeyfile " +
                      dir.file("server.key") + "\nallow_anonymous true\n");

    auto wrong =
        start_bridge(dir, daemon, broker, {"--in", "t/#=/mqtt/wrong", "--cafile", dir.file("other.crt")},
                     "wrong", {}, false);
    EXPECT_TRUE(eventually([&] { return wrong->out().find("retrying") != std::string::npos; }))
        << wrong->out();
    EXPECT_EQ(wrong->out().find("subscribed"), std::string::npos) << wrong->out();
    EXPECT_TRUE(wrong->running());

    auto right =
        start_bridge(dir, daemon, broker, {"--in", "t/#=/mqtt/tls", "--cafile", dir.file("ca.crt")}, "right");
    Reader reader(dir, daemon, "/mqtt/tls", "/test/reader");
    run_tool(dir,
             {"/usr/bin/mosquitto_pub", "-p", std::to_string(broker.port()), "-h", "127.0.0.1", "--cafile",
              dir.file("ca.crt"), "-t", "t/1", "-m", "\"secret\""},
             "pub");
    EXPECT_EQ(reader.next(), json("secret"));
}

TEST(BridgeMqtt_test, UsageMistakesExitTwoNamingTheFlag) {
    TempDir dir;
    Daemon daemon(dir, "n1");
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases{
        {{"--broker", "localhost", "--in", "a=/p"}, "--broker"},
        {{"--broker", "localhost:0", "--in", "a=/p"}, "--broker"},
        {{"--in", "a/#/b=/p"}, "not an MQTT topic pattern"},
        {{"--out", "/p=a/+"}, "no '+' or '#'"},
        {{"--in", "a/b"}, "expected FROM=TO"},
        {{"--in", "a=p"}, "is not a port name"},
        {{"--in", "a=/p", "--in", "b=/p"}, "mapped twice"},
    };
    for (const auto& [args, expected] : cases) {
        std::vector<std::string> argv{PLEXUS_BRIDGE, "mqtt"};
        argv.insert(argv.end(), args.begin(), args.end());
        Process bridge(argv, daemon.env(), dir.file("usage"));
        EXPECT_EQ(bridge.wait(), 2) << args[1];
        EXPECT_NE(bridge.err().find(expected), std::string::npos) << bridge.err();
    }
}

}  // namespace bridge_mqtt_test
}  // namespace plexus::test
