// A man in the middle (issue 32): a host on the path between two daemons, and between one of them
// and the name server, relays every byte and datagram (a relay of the test's own, on its own
// network namespace) and keeps a capture. With the deployment secret every TCP link is TLS 1.3 and
// every udp datagram is sealed: the capture holds no payload, no port name and no node name; every
// record or datagram the relay alters, injects or replays is refused and counted by the daemon
// that reads it (datagrams recorded before the reader restarted too), and the stream comes back by
// itself. Without a secret (--insecure), the same capture reads everything: the check can fail.
//
// Hosts: the name server on 0, the writing daemon on 1, the reading daemon on 2, the relay on 3.
// The writer reaches the name server through the relay (--names RELAY:PORT), and the reader
// advertises the relay's address (--advertise), so the writer's link to it crosses the relay too.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "harness.hpp"
#include "netns.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace mitm_test {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

constexpr std::string_view writer_node = "mitm-writer-node";
constexpr std::string_view reader_node = "mitm-reader-node";
constexpr std::string_view payload_mark = "mitm-payload-";

int port_of(const std::string& host_port) {
    return std::stoi(host_port.substr(host_port.rfind(':') + 1));
}

sockaddr_in address_of(const std::string& host, int port) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, host.c_str(), &address.sin_addr);
    return address;
}

int udp_bound(const std::string& host, int port) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    const auto address = address_of(host, port);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
        return -1;
    return fd;
}

int listen_on(const std::string& host, int port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, host.c_str(), &address.sin_addr);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, 16) != 0)
        return -1;
    return fd;
}

int connect_to(const std::string& host, int port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, host.c_str(), &address.sin_addr);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
        ::close(fd);
        return -1;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return fd;
}

bool write_all(int fd, const std::uint8_t* bytes, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::send(fd, bytes, size, MSG_NOSIGNAL);
        if (n <= 0)
            return false;
        bytes += n;
        size -= static_cast<std::size_t>(n);
    }
    return true;
}

/// One relayed connection. The bytes from the connecting side are passed on a TLS record at a time
/// (5-byte header: type, version, length), so that an attack lands between two records: a flipped
/// byte inside the next application-data record, a forged record before it, or the last one again.
struct Relayed {
    int from = -1;  ///< the connecting side
    int to = -1;    ///< the relay's connection to the target
    bool attackable = false;
    std::vector<std::uint8_t> pending;  ///< connecting side's bytes not yet a whole record
    std::vector<std::uint8_t> last_record;
    int application_records = 0;
};

/// The attack named in the file `attack`, if any: read once, then the file is gone and
/// `attack`.done says it was carried out.
std::string take_attack(const std::string& attack, const std::string& prefix) {
    if (!std::filesystem::exists(attack))
        return {};
    std::string what;
    std::ifstream(attack) >> what;
    if (what.rfind(prefix, 0) != 0)
        return {};
    std::filesystem::remove(attack);
    std::ofstream(attack + ".done") << what;
    return what;
}

/// The relay's datagrams: every one from the writer goes on to `target` (from the relay's own
/// address, as the reader's link does), kept in the capture and in `history`. The attacks that
/// start with "datagram-" land on the next one.
struct DatagramRelay {
    int fd = -1;
    sockaddr_in target{};
    std::vector<std::vector<std::uint8_t>> history;

    void pass(std::ofstream& out, const std::string& attack) {
        std::vector<std::uint8_t> datagram(65536);
        const ssize_t n = ::recv(fd, datagram.data(), datagram.size(), MSG_DONTWAIT);
        if (n <= 0)
            return;
        datagram.resize(static_cast<std::size_t>(n));
        out.write(reinterpret_cast<const char*>(datagram.data()), n).flush();
        const std::string what = history.empty() ? std::string{} : take_attack(attack, "datagram-");
        if (what == "datagram-flip") {
            datagram[datagram.size() - 20] ^= 0x01;  // in the fragment, before the 16-byte tag
        } else if (what == "datagram-forge") {
            // The last datagram's header, then bytes of the relay's choosing where the sealed
            // fragment and its tag were.
            auto forged = history.back();
            for (std::size_t i = forged.size() - 40; i < forged.size(); ++i)
                forged[i] = static_cast<std::uint8_t>(i * 37 + 11);
            send(forged);
        } else if (what == "datagram-replay") {
            send(history.back());
        } else if (what == "datagram-replay-all") {
            for (const auto& old : history)
                send(old);
        }
        send(datagram);
        history.push_back(std::move(datagram));
    }
    void send(const std::vector<std::uint8_t>& datagram) const {
        ::sendto(fd, datagram.data(), datagram.size(), 0, reinterpret_cast<const sockaddr*>(&target),
                 sizeof target);
    }
};

/// The relay's body, inside its host: forwards `listen_host`:P to `targets[P]`:P for each port P,
/// appends every byte either way to `capture`, and, on the connections to `attack_port`, applies
/// the attack named in the file `attack` (then removes it) before the next application-data record.
/// Datagrams to `listen_host`:`datagram_port` go on to its target likewise (DatagramRelay).
int relay(const std::string& listen_host, const std::map<int, std::string>& targets, int attack_port,
          int datagram_port, const std::string& capture, const std::string& attack,
          const std::string& ready) {
    std::map<int, int> listeners;  // fd -> port
    for (const auto& [port, target] : targets) {
        const int fd = listen_on(listen_host, port);
        if (fd < 0)
            return 10;
        listeners[fd] = port;
    }
    DatagramRelay datagrams;
    datagrams.fd = udp_bound(listen_host, datagram_port);
    if (datagrams.fd < 0)
        return 12;
    datagrams.target = address_of(targets.at(datagram_port), datagram_port);
    std::ofstream(ready) << "ready";
    std::ofstream out(capture, std::ios::binary);
    std::vector<Relayed> relayed;
    for (;;) {
        std::vector<pollfd> watched;
        watched.push_back({datagrams.fd, POLLIN, 0});
        for (const auto& [fd, port] : listeners)
            watched.push_back({fd, POLLIN, 0});
        for (const auto& r : relayed) {
            watched.push_back({r.from, POLLIN, 0});
            watched.push_back({r.to, POLLIN, 0});
        }
        if (::poll(watched.data(), watched.size(), 1000) < 0)
            return 11;
        std::size_t at = 0;
        if (watched[at++].revents & POLLIN)
            datagrams.pass(out, attack);
        const std::size_t polled = relayed.size();  // those accepted below were not polled yet
        for (const auto& [fd, port] : listeners) {
            if (watched[at++].revents & POLLIN) {
                Relayed r;
                r.from = ::accept4(fd, nullptr, nullptr, SOCK_CLOEXEC);
                r.to = connect_to(targets.at(port), port);
                r.attackable = port == attack_port;
                if (r.from >= 0 && r.to >= 0)
                    relayed.push_back(std::move(r));
            }
        }
        std::vector<std::size_t> ended;
        for (std::size_t i = 0; i < polled; ++i) {
            auto& r = relayed[i];
            const short from_events = watched[at++].revents;
            const short to_events = watched[at++].revents;
            std::uint8_t chunk[65536];
            bool gone = false;
            if (to_events & (POLLIN | POLLHUP | POLLERR)) {
                const ssize_t n = ::recv(r.to, chunk, sizeof chunk, 0);
                if (n > 0)  // in the capture before it goes on: the test reads it once a message arrived
                    out.write(reinterpret_cast<const char*>(chunk), n).flush();
                gone = n <= 0 || !write_all(r.from, chunk, static_cast<std::size_t>(n));
            }
            if (!gone && (from_events & (POLLIN | POLLHUP | POLLERR))) {
                const ssize_t n = ::recv(r.from, chunk, sizeof chunk, 0);
                gone = n <= 0;
                if (n > 0) {
                    out.write(reinterpret_cast<const char*>(chunk), n).flush();
                    r.pending.insert(r.pending.end(), chunk, chunk + n);
                }
                // Whole records on, one by one.
                while (!gone && r.pending.size() >= 5) {
                    const std::size_t size = 5 + (std::size_t(r.pending[3]) << 8 | r.pending[4]);
                    if (r.pending.size() < size)
                        break;
                    std::vector<std::uint8_t> record(r.pending.begin(), r.pending.begin() + size);
                    r.pending.erase(r.pending.begin(), r.pending.begin() + size);
                    const bool application = record[0] == 0x17;
                    const std::string what = application && r.attackable && r.application_records > 0
                                                 ? take_attack(attack, "record-")
                                                 : std::string{};
                    if (!what.empty()) {
                        if (what == "record-flip") {
                            record[5 + (size - 5) / 2] ^= 0x01;
                        } else if (what == "record-inject") {
                            std::vector<std::uint8_t> forged{0x17, 0x03, 0x03, 0x00, 0x40};
                            for (int b = 0; b < 0x40; ++b)
                                forged.push_back(static_cast<std::uint8_t>(b * 37 + 11));
                            gone = !write_all(r.to, forged.data(), forged.size());
                        } else if (what == "record-replay") {
                            gone = !write_all(r.to, r.last_record.data(), r.last_record.size());
                        }
                    }
                    if (application) {
                        ++r.application_records;
                        r.last_record = record;
                    }
                    gone = gone || !write_all(r.to, record.data(), record.size());
                }
                if (!r.attackable && !gone && !r.pending.empty()) {
                    // Not the attacked link: nothing to hold back (and it may not even be TLS).
                    gone = !write_all(r.to, r.pending.data(), r.pending.size());
                    r.pending.clear();
                }
            }
            if (gone)
                ended.push_back(i);
        }
        for (auto it = ended.rbegin(); it != ended.rend(); ++it) {
            ::close(relayed[*it].from);
            ::close(relayed[*it].to);
            relayed.erase(relayed.begin() + static_cast<std::ptrdiff_t>(*it));
        }
    }
}

/// The four hosts, the relay, and the two daemons, the writer's and the reader's links through it.
struct PathThroughARelay {
    explicit PathThroughARelay(bool secret)
        : net(4), names(dir, net.host(0), secret ? std::vector<std::string>{} : insecure) {
        // The reader first, advertising the relay's address at its own port.
        reader = std::make_unique<Daemon>(dir, net.host(2), std::string(reader_node), names.address(),
                                          with(secret, {"--advertise", net.host(3).address()}));
        const int reader_port = port_of(reader->address());
        const int names_port = port_of(names.address());
        const std::string ready = dir.file("relay.ready");
        relay_pid = net.host(3).fork_inside([&, secret] {
            return relay(net.host(3).address(),
                         {{names_port, net.host(0).address()}, {reader_port, net.host(2).address()}},
                         secret ? reader_port : -1, reader_port, capture_file(), attack_file(), ready);
        });
        if (!eventually([&] { return std::filesystem::exists(ready); }, 20s))
            throw std::runtime_error("the relay did not start");
        writer = std::make_unique<Daemon>(dir, net.host(1), std::string(writer_node),
                                          net.host(3).address() + ":" + std::to_string(names_port),
                                          with(secret, {}));
    }
    ~PathThroughARelay() {
        ::kill(relay_pid, SIGKILL);
        wait_child(relay_pid);
    }
    std::vector<std::string> with(bool secret, std::vector<std::string> extra) const {
        if (!secret)
            extra.insert(extra.end(), insecure.begin(), insecure.end());
        return extra;
    }
    std::string capture_file() const { return dir.file("capture"); }
    std::string attack_file() const { return dir.file("attack"); }
    std::string capture() const {
        std::ifstream in(capture_file(), std::ios::binary);
        std::stringstream bytes;
        bytes << in.rdbuf();
        return bytes.str();
    }
    json reader_stats() {
        auto stats = run_cli(dir, *reader, {"stats", "--json"});
        return stats.status == 0 ? json::parse(stats.out)["daemon"] : json{};
    }

    const std::vector<std::string> insecure{"--insecure"};
    TempDir dir;
    Network net;
    NameServerProcess names;
    std::unique_ptr<Daemon> reader;
    std::unique_ptr<Daemon> writer;
    pid_t relay_pid = -1;
};

std::string out_port() {
    return "/" + std::string(writer_node) + "/out";
}
std::string in_port() {
    return "/" + std::string(reader_node) + "/in";
}

/// The path, a writer on one daemon and a reader on the other, connected (persistent) through the
/// relay by `carrier`; the messages written, numbered, and those read.
struct StreamThroughARelay {
    explicit StreamThroughARelay(bool secret, const std::string& carrier = "tcp")
        : path(secret),
          writing({path.writer->socket()}),
          reading(std::make_unique<Client>(Client::Options{path.reader->socket()})),
          source(writing.open(out_port())),
          sink(reading->open(in_port())) {
        writing.connect(out_port(), in_port(), carrier, true);
    }
    /// The reader's daemon restarted (killed, started again): its port opened again.
    void restart_reader() {
        sink.reset();
        reading.reset();
        path.reader->start_again();
        reading = std::make_unique<Client>(Client::Options{path.reader->socket()});
        sink = reading->open(in_port());
    }
    /// Writes the next numbered message.
    void write() { source.write(json(std::string(payload_mark) + std::to_string(next++))); }
    /// Reads one message within `timeout`: its number. The stream hands messages on in order and
    /// each once, so a number not above the last one read is a replay that got through (messages
    /// still on their way when a step of the test ended arrive later, and are above it).
    std::optional<std::uint64_t> read(std::chrono::milliseconds timeout) {
        auto message = sink->read(timeout);
        if (!message)
            return std::nullopt;
        const auto text = message->data.get<std::string>();
        const std::uint64_t number = std::stoull(text.substr(payload_mark.size()));
        if (number <= last_read)
            replays_read.push_back(number);
        last_read = std::max(last_read, number);
        return number;
    }
    /// Writes a message at a time until the reader has one written from now on; true when one came
    /// within `timeout`.
    bool flows(std::chrono::milliseconds timeout) {
        const std::uint64_t from = next;
        const auto deadline = Clock::now() + timeout;
        while (Clock::now() < deadline) {
            write();
            while (auto number = read(20ms)) {
                if (*number >= from)
                    return true;
            }
        }
        return false;
    }
    /// Reads whatever arrives for a while.
    void read_for(std::chrono::milliseconds time) {
        const auto until = Clock::now() + time;
        while (Clock::now() < until)
            read(20ms);
    }

    PathThroughARelay path;
    Client writing;
    std::unique_ptr<Client> reading;
    Port source;
    std::optional<Port> sink;
    std::uint64_t next = 1;
    std::uint64_t last_read = 0;
    std::vector<std::uint64_t> replays_read;  ///< numbers read again, or after a later one
};

/// What a relay must not read with the secret, and reads without it.
std::vector<std::string> plain_texts() {
    return {std::string(payload_mark), out_port(), in_port(), std::string(writer_node),
            std::string(reader_node)};
}

TEST(Mitm_test, ARelayOnThePathReadsNothingAndEveryRecordItAltersInjectsOrReplaysIsRefusedAndCounted) {
    PLEXUS_NEEDS_NETNS();
    StreamThroughARelay stream(true);
    auto& path = stream.path;
    ASSERT_TRUE(stream.flows(30s)) << path.writer->process().err();

    for (const std::string attack : {"record-flip", "record-inject", "record-replay"}) {
        const auto refused_before = path.reader_stats().value("tls_records_refused", std::uint64_t{0});
        std::filesystem::remove(path.attack_file() + ".done");
        std::ofstream(path.attack_file()) << attack;
        // The relay attacks the next record of the writer's link: the reader refuses it, counts it,
        // and the link is made again by itself.
        ASSERT_TRUE(eventually(
            [&] {
                stream.write();
                while (stream.read(1ms)) {
                }
                return std::filesystem::exists(path.attack_file() + ".done");
            },
            30s))
            << attack << ": the relay saw no record to attack";
        EXPECT_TRUE(eventually(
            [&] {
                return path.reader_stats().value("tls_records_refused", std::uint64_t{0}) > refused_before;
            },
            30s))
            << attack << " was not counted: " << path.reader_stats().dump();
        ASSERT_TRUE(stream.flows(60s))
            << attack << ": the stream did not come back\n--- writer:\n"
            << path.writer->process().out() << path.writer->process().err() << "\n--- reader:\n"
            << path.reader->process().out() << path.reader->process().err();
    }
    EXPECT_TRUE(stream.replays_read.empty()) << "a replayed message got through: " << stream.replays_read[0];
    const auto log = path.reader->process().out() + path.reader->process().err();
    EXPECT_NE(log.find("the encrypted link broke"), std::string::npos) << log;

    // What the relay saw: ciphertext. Not one payload, port name or node name.
    const std::string capture = path.capture();
    EXPECT_GT(capture.size(), 4000u);  // every message of the test, and the handshakes
    for (const auto& plain : plain_texts())
        EXPECT_EQ(capture.find(plain), std::string::npos) << "the relay read '" << plain << "'";
}

std::uint64_t reader_counter(PathThroughARelay& path, const std::string& name) {
    return path.reader_stats().value(name, std::uint64_t{0});
}

TEST(Mitm_test, EveryDatagramTheRelayAltersForgesOrReplaysIsRefusedEvenAfterTheReaderRestarts) {
    PLEXUS_NEEDS_NETNS();
    StreamThroughARelay stream(true, "udp");
    auto& path = stream.path;
    ASSERT_TRUE(stream.flows(30s)) << path.writer->process().err();

    // The relay attacks the next datagram after the file names the attack.
    auto carry_out = [&](const std::string& attack) {
        std::filesystem::remove(path.attack_file() + ".done");
        std::ofstream(path.attack_file()) << attack;
        return eventually(
            [&] {
                stream.write();
                while (stream.read(1ms)) {
                }
                return std::filesystem::exists(path.attack_file() + ".done");
            },
            30s);
    };
    for (const std::string attack : {"datagram-flip", "datagram-forge"}) {
        const auto refused_before = reader_counter(path, "udp_bad_mac");
        ASSERT_TRUE(carry_out(attack)) << attack << ": the relay saw no datagram to attack";
        EXPECT_TRUE(eventually([&] { return reader_counter(path, "udp_bad_mac") > refused_before; }, 30s))
            << attack << " was not refused: " << path.reader_stats().dump();
        ASSERT_TRUE(stream.flows(30s)) << attack;
    }
    // The last datagram again: it opens (same stream, same key), and the stream refuses it as late.
    const auto late = [&] {
        const auto inbound = inbound_stats(path.dir, *path.reader, in_port(), out_port());
        return inbound.is_null() ? std::uint64_t{0} : inbound.value("late", std::uint64_t{0});
    };
    const auto late_before = late();
    ASSERT_TRUE(carry_out("datagram-replay"));
    EXPECT_TRUE(eventually([&] { return late() > late_before; }, 30s));
    stream.read_for(300ms);
    EXPECT_TRUE(stream.replays_read.empty())
        << "the replayed message got through: " << stream.replays_read[0];

    // The reader's daemon restarts; the writer's persistent connection is made again, with a new
    // stream (numbered from 1 again) and a new key. Every datagram of before, replayed, is refused:
    // those of the stream before the restart open under no key the reader holds (or name a stream
    // it no longer has), those of the new one are late.
    stream.restart_reader();
    ASSERT_TRUE(stream.flows(60s)) << "the stream did not come back after the restart\n--- writer:\n"
                                   << path.writer->process().out() << path.writer->process().err();
    const auto refused = [&] {
        return reader_counter(path, "udp_bad_mac") + reader_counter(path, "udp_unknown_stream");
    };
    const auto refused_before = refused();
    ASSERT_TRUE(carry_out("datagram-replay-all"));
    EXPECT_TRUE(eventually([&] { return refused() > refused_before; }, 30s)) << path.reader_stats().dump();
    stream.read_for(300ms);
    EXPECT_TRUE(stream.replays_read.empty()) << "a replayed message got through: " << stream.replays_read[0];
    ASSERT_TRUE(stream.flows(30s));

    // What the relay saw of the payloads: sealed datagrams.
    const std::string capture = path.capture();
    EXPECT_EQ(capture.find(std::string(payload_mark)), std::string::npos) << "the relay read a payload";
}

TEST(Mitm_test, WithoutASecretTheSameRelayReadsPayloadsPortsAndNodes) {
    PLEXUS_NEEDS_NETNS();
    StreamThroughARelay stream(false);
    ASSERT_TRUE(stream.flows(30s));
    const std::string capture = stream.path.capture();
    for (const auto& plain : plain_texts())
        EXPECT_NE(capture.find(plain), std::string::npos) << "the plain capture lacks '" << plain << "'";
}

TEST(Mitm_test, WithoutASecretTheSameRelayReadsUdpPayloads) {
    PLEXUS_NEEDS_NETNS();
    StreamThroughARelay stream(false, "udp");
    ASSERT_TRUE(stream.flows(30s));
    EXPECT_NE(stream.path.capture().find(std::string(payload_mark)), std::string::npos);
}

}  // namespace mitm_test
}  // namespace plexus::test
