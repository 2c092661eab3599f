// The web endpoint (plexusd --http, docs/WEB.md): its page and views, /metrics against `plexus
// stats`, the live stream's rate, the page in a real browser, and what a hostile or broken client
// can do to it. The test across hosts (a page showing another daemon, the token beyond loopback)
// is in web_hosts_test.cpp.
#include <sys/resource.h>
#include <sys/socket.h>

#include <algorithm>
#include <fstream>

#include <gtest/gtest.h>

#include "harness.hpp"
#include "http_client.hpp"
#include "web_paths.hpp"

namespace plexus::test {
namespace web_test {

using nlohmann::json;

/// A daemon with the web endpoint on a free loopback port, at the address `plexus web` prints.
class WebDaemon {
public:
    explicit WebDaemon(const TempDir& dir, const json& config = json::object())
        : daemon_(
              dir, "web", "",
              {"--http", "127.0.0.1:0", "--scripts", monitors_dir(), "--config", write_config(dir, config)}) {
        auto printed = run_cli(dir, daemon_, {"web"});
        if (printed.status != 0)
            throw std::runtime_error("plexus web failed: " + printed.err);
        url_ = printed.out.substr(0, printed.out.find('\n'));
        address_ = url_.substr(std::string("http://").size());
        address_.pop_back();  // the trailing '/'
    }
    Daemon& daemon() { return daemon_; }
    const std::string& url() const { return url_; }
    const std::string& address() const { return address_; }
    json get_json(const std::string& path) const {
        auto reply = http_get(address_, path);
        if (reply.status != 200)
            throw std::runtime_error("GET " + path + ": " + std::to_string(reply.status) + " " + reply.body);
        return json::parse(reply.body);
    }
    /// The endpoint's counters, as `plexus stats` shows them (asked over the Unix socket, so it
    /// works while the endpoint itself is full).
    json http_counters(const TempDir& dir) const {
        auto stats = run_cli(dir, daemon_, {"stats", "--json"});
        return stats.status == 0 ? json::parse(stats.out).value("http", json()) : json();
    }

private:
    static std::string write_config(const TempDir& dir, const json& config) {
        const std::string path = dir.file("web-config.json");
        std::ofstream(path) << config.dump();
        return path;
    }
    Daemon daemon_;
    std::string url_;
    std::string address_;
};

std::uint64_t refused(const json& counters, const char* reason) {
    return counters.is_object() ? counters["refused"].value(reason, std::uint64_t{0}) : 0;
}

/// A writer and a reader connected /web/out -> /web/in (arbitrated: recv.priority), `count`
/// messages through them. Both stay open (the port stays arbitrated) until the end of the test.
struct Traffic {
    Traffic(const TempDir& dir, Daemon& daemon, int count)
        : reader(start_cli(dir, daemon, {"read", "/web/in"}, "reader")),
          writer(dir, daemon, "/web/out", "writer") {
        if (!wait_port(dir, daemon, "/web/in") || !wait_port(dir, daemon, "/web/out"))
            throw std::runtime_error("the ports did not appear");
        auto connected = run_cli(dir, daemon,
                                 {"connect", "/web/out", "/web/in",
                                  "local+recv.portmonitor+type.lua+file.rate_logger+recv.priority+tc.0.5"});
        if (connected.status != 0)
            throw std::runtime_error("connect failed: " + connected.err);
        writer.send(numbered_lines(0, count));
        const bool arrived = eventually(
            [&] { return port_stats(dir, daemon, "/web/in").value("received", 0) >= count; }, slower(30s));
        if (!arrived)
            throw std::runtime_error("the messages did not arrive: " +
                                     port_stats(dir, daemon, "/web/in").dump());
    }
    std::unique_ptr<Process> reader;
    CliWriter writer;
};

TEST(Web_test, ServesThePageItsFilesAndTheViewsThePlexusStatsAndEventsCommandsShow) {
    TempDir dir;
    WebDaemon web(dir);
    Traffic traffic(dir, web.daemon(), 20);

    auto page = http_get(web.address(), "/");
    ASSERT_EQ(page.status, 200);
    EXPECT_EQ(page.headers["content-type"], "text/html; charset=utf-8");
    EXPECT_NE(page.body.find("/static/app.js"), std::string::npos) << page.body;
    auto script = http_get(web.address(), "/static/app.js");
    EXPECT_EQ(script.status, 200);
    EXPECT_EQ(script.headers["content-type"], "text/javascript; charset=utf-8");

    const auto node = web.get_json("/api/node");
    EXPECT_EQ(node["node"], "web");
    EXPECT_EQ(node["http"], web.address());
    const auto stats = web.get_json("/api/stats");
    const auto cli_stats = json::parse(run_cli(dir, web.daemon(), {"stats", "--json"}).out);
    ASSERT_EQ(stats["ports"].size(), cli_stats["ports"].size());
    for (std::size_t i = 0; i < stats["ports"].size(); ++i)  // quiet: the same counters
        EXPECT_EQ(stats["ports"][i]["received"], cli_stats["ports"][i]["received"]);
    const auto events = web.get_json("/api/events?port=%2Fweb%2Fin");
    EXPECT_EQ(events["port"], "/web/in");
    ASSERT_EQ(events["connections"].size(), 1u) << events;
    EXPECT_EQ(events["connections"][0]["source"], "/web/out");
    EXPECT_EQ(events["connections"][0]["counters"]["received"], 20);
    EXPECT_EQ(http_get(web.address(), "/api/events?port=/nowhere").status, 404);

    const auto system = web.get_json("/api/system");
    ASSERT_EQ(system["nodes"].size(), 1u) << system;
    EXPECT_EQ(system["nodes"][0]["node"], "web");
    EXPECT_TRUE(system["nodes"][0]["error"].is_null());
    ASSERT_EQ(system["nodes"][0]["arbitration"].size(), 1u);
    EXPECT_EQ(system["nodes"][0]["arbitration"][0]["port"], "/web/in");
    EXPECT_EQ(system["names"]["ports"].size(), 2u) << system["names"];

    const auto messages = web.get_json("/api/messages?port=/web/in");
    EXPECT_EQ(messages["port"], "/web/in");
    EXPECT_TRUE(messages["messages"].is_array());
}

TEST(Web_test, MetricsParseAsPrometheusTextAndEqualPlexusStats) {
    TempDir dir;
    WebDaemon web(dir);
    Traffic traffic(dir, web.daemon(), 50);

    // Quiet now: nothing moves between the two questions but the CLI's own session.
    auto metrics = http_get(web.address(), "/metrics");
    ASSERT_EQ(metrics.status, 200);
    EXPECT_EQ(metrics.headers["content-type"], "text/plain; version=0.0.4; charset=utf-8");
    auto stats = run_cli(dir, web.daemon(), {"stats", "--json"});
    ASSERT_EQ(stats.status, 0);
    std::ofstream(dir.file("metrics.txt")) << metrics.body;
    std::ofstream(dir.file("stats.json")) << stats.out;
    Process check({python_path(), web_tests_dir() + "/metrics_check.py", dir.file("metrics.txt"),
                   dir.file("stats.json")},
                  {}, dir.file("metrics_check"));
    ASSERT_EQ(check.wait(slower(60s)), 0) << check.out() << check.err();
    EXPECT_NE(metrics.body.find("plexus_port_received_total{node=\"web\",port=\"/web/in\"} 50"),
              std::string::npos)
        << metrics.body;
    EXPECT_NE(metrics.body.find("# TYPE plexus_monitor_cost_seconds histogram"), std::string::npos);
}

TEST(Web_test, RefusesBadRequestsWithTheRightStatusAndCountsEachOne) {
    TempDir dir;
    WebDaemon web(dir);
    EXPECT_EQ(http_get(web.address(), "/no/such/path").status, 404);
    // 64 KiB of headers: 431, and the connection closed.
    EXPECT_EQ(http_get(web.address(), "/", "X-Big: " + std::string(64 * 1024, 'a') + "\r\n").status, 431);
    {
        HttpConnection connection(web.address());
        connection.send("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5\r\n\r\nhello");
        EXPECT_EQ(connection.read_reply().status, 400);
        EXPECT_TRUE(connection.closed_by_peer(slower(5s)));
    }
    {
        HttpConnection connection(web.address());
        connection.send("POST /api/stats HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 0\r\n\r\n");
        auto reply = connection.read_reply();
        EXPECT_EQ(reply.status, 405);
        EXPECT_EQ(reply.headers["allow"], "GET, HEAD");
    }
    {
        HttpConnection connection(web.address());
        connection.send("NOT-HTTP\r\n\r\n");
        EXPECT_EQ(connection.read_reply().status, 400);
    }
    // A name in Host, no token: a page elsewhere whose name now points at 127.0.0.1.
    EXPECT_EQ(http_get(web.address(), "/api/stats", "Host: evil.example\r\n").status, 403);
    EXPECT_EQ(http_get(web.address(), "/login?token=wrong").status, 401);

    EXPECT_EQ(http_get(web.address(), "/api/node").status, 200);  // still serving
    const auto counters = web.http_counters(dir);
    EXPECT_GE(refused(counters, "not_found"), 1u) << counters;
    EXPECT_GE(refused(counters, "header_too_large"), 1u) << counters;
    EXPECT_GE(refused(counters, "body"), 1u) << counters;
    EXPECT_GE(refused(counters, "method"), 1u) << counters;
    EXPECT_GE(refused(counters, "bad_request"), 1u) << counters;
    EXPECT_GE(refused(counters, "host"), 1u) << counters;
    EXPECT_GE(refused(counters, "token"), 1u) << counters;
}

TEST(Web_test, AThousandConnectionsHeldLeaveTheDaemonServingWithBoundedMemory) {
    // 1,000 sockets here and 1,000 in the daemon: more than a soft limit of 1,024 descriptors.
    rlimit files{};
    if (::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
        files.rlim_cur = files.rlim_max;
        ::setrlimit(RLIMIT_NOFILE, &files);
    }
    TempDir dir;
    WebDaemon web(dir, {{"http_read_timeout_ms", 60000}});
    const long idle_kib = web.daemon().rss_kib();
    std::vector<std::unique_ptr<HttpConnection>> held;
    for (int i = 0; i < 1000; ++i) {
        held.push_back(std::make_unique<HttpConnection>(web.address()));
        ASSERT_TRUE(held.back()->connected()) << "connection " << i;
    }
    json counters;
    ASSERT_TRUE(eventually(
        [&] {
            counters = web.http_counters(dir);
            return counters.value("connections_accepted", 0) >= 1000;
        },
        slower(30s)))
        << counters;
    EXPECT_LE(counters["connections_open"].get<int>(), 256) << counters;
    EXPECT_GE(refused(counters, "too_many_connections"), 744u) << counters;
    // The data path does not notice.
    Traffic traffic(dir, web.daemon(), 100);
    EXPECT_LT(web.daemon().rss_kib() - idle_kib, 64 * 1024) << "idle " << idle_kib << " KiB";
    held.clear();
    ASSERT_TRUE(eventually([&] { return http_get(web.address(), "/api/node").status == 200; }, slower(10s)));
}

TEST(Web_test, ASlowLorisClientIsCutOffOnceItsRequestIsLate) {
    TempDir dir;
    WebDaemon web(dir, {{"http_read_timeout_ms", 500}});
    HttpConnection connection(web.address());
    ASSERT_TRUE(connection.send("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n"));
    // One header byte at a time, each well within any per-read timeout: only a deadline for the
    // whole request stops it.
    const auto started = std::chrono::steady_clock::now();
    bool cut = false;
    while (!cut && std::chrono::steady_clock::now() - started < slower(20s)) {
        connection.send("X");
        cut = connection.closed_by_peer(100ms);
    }
    EXPECT_TRUE(cut);
    ASSERT_TRUE(
        eventually([&] { return refused(web.http_counters(dir), "read_timeout") >= 1; }, slower(10s)));
    EXPECT_EQ(http_get(web.address(), "/api/node").status, 200);
}

TEST(Web_test, AStreamClientThatNeverReadsIsDroppedAndCounted) {
    TempDir dir;
    WebDaemon web(dir, {{"http_write_timeout_ms", 500}, {"http_stream_backlog_bytes", 65536}});
    Traffic traffic(dir, web.daemon(), 10);  // an arbitrated port: the stream sends 20 events a second
    HttpConnection stuck(web.address(), 4096);
    ASSERT_TRUE(stuck.send("GET /api/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"));
    json counters;
    ASSERT_TRUE(eventually(
        [&] {
            counters = web.http_counters(dir);
            return refused(counters, "slow_stream") >= 1 && counters["stream_clients"] == 0;
        },
        slower(120s)))
        << counters;
    EXPECT_EQ(http_get(web.address(), "/api/node").status, 200);
}

TEST(Web_test, TheStreamSendsEveryArbitratedPortTwentyTimesASecond) {
    TempDir dir;
    WebDaemon web(dir);
    Traffic traffic(dir, web.daemon(), 10);
    HttpConnection stream(web.address());
    ASSERT_TRUE(stream.send("GET /api/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"));
    const std::string text = stream.read_for(3s);
    ASSERT_EQ(text.rfind("HTTP/1.1 200 OK\r\n", 0), 0u) << text.substr(0, 200);
    EXPECT_NE(text.find("Content-Type: text/event-stream"), std::string::npos);
    std::vector<double> times;
    bool saw_system = false;
    for (std::size_t at = text.find("event: "); at != std::string::npos; at = text.find("event: ", at + 1)) {
        const auto name_end = text.find('\n', at);
        const auto name = text.substr(at + 7, name_end - at - 7);
        const auto data_end = text.find("\n\n", name_end);
        if (data_end == std::string::npos)
            break;  // cut at the end of the read
        const auto data = json::parse(text.substr(name_end + 7, data_end - name_end - 7));
        if (name == "system")
            saw_system = true;
        if (name == "arbitration") {
            times.push_back(data["t"].get<double>());
            ASSERT_EQ(data["ports"][0]["port"], "/web/in");
            const auto& connection = data["ports"][0]["connections"][0];
            EXPECT_EQ(connection["source"], "/web/out");
            EXPECT_TRUE(connection["S"].is_number());
        }
    }
    EXPECT_TRUE(saw_system);
    ASSERT_GE(times.size(), 10u);
    std::vector<double> gaps;
    for (std::size_t i = 1; i < times.size(); ++i)
        gaps.push_back(times[i] - times[i - 1]);
    std::sort(gaps.begin(), gaps.end());
    // The daemon's own clock says when it sent each: its median period is 50 ms (20 Hz).
    EXPECT_LE(gaps[gaps.size() / 2], 0.051 * slowdown()) << "median gap of " << gaps.size() << " events";
}

TEST(Web_test, TheBrowserShowsTheGazeDemoAndTheWinnerChangingWhenTheObjectDetectorStops) {
    if (std::getenv("PLEXUS_SKIP_BROWSER"))
        GTEST_SKIP() << "PLEXUS_SKIP_BROWSER is set";
    TempDir dir;
    WebDaemon web(dir);
    auto& daemon = web.daemon();
    auto reader = start_cli(dir, daemon, {"read", "/gaze/in", "--policy", "latest"}, "gaze");
    // Always seen, both: the object wins while it streams, the face once it stops.
    Process face({detector_path(), "/demo/face/out", "--kind", "face", "--gone", "0", "--low", "0.6"},
                 daemon.env(), dir.file("face"));
    Process object({detector_path(), "/demo/object/out", "--kind", "object", "--gone", "0", "--low", "0.6"},
                   daemon.env(), dir.file("object"));
    for (const char* port : {"/gaze/in", "/demo/face/out", "/demo/object/out"})
        ASSERT_TRUE(wait_port(dir, daemon, port)) << port;
    const std::string monitor = "recv.portmonitor+type.lua+file.certainty+threshold.0.5+lifetime.0.5";
    ASSERT_EQ(run_cli(dir, daemon,
                      {"connect", "/demo/face/out", "/gaze/in",
                       "local+" + monitor + "+event.e_face_seen+recv.priority+tc.0.5"})
                  .status,
              0);
    ASSERT_EQ(run_cli(dir, daemon,
                      {"connect", "/demo/object/out", "/gaze/in",
                       "local+" + monitor + "+event.e_object_seen+recv.priority+tc.0.5+ex./demo/face/out:-1"})
                  .status,
              0);
    const std::string artefacts = artefacts_dir();
    Process browser({python_path(), web_tests_dir() + "/page_test.py", web.url(), artefacts, "--stop-winner",
                     "/demo/object/out=" + std::to_string(object.pid()), "--timeout", "60"},
                    {}, dir.file("browser"));
    const auto status = browser.wait(slower(240s));
    EXPECT_EQ(status, 0) << browser.out() << browser.err();
    EXPECT_NE(browser.out().find("page: winner changed from /demo/object/out to /demo/face/out"),
              std::string::npos)
        << browser.out();
    std::cout << "screenshot: " << artefacts << "/web-page.png\n";
}

}  // namespace web_test
}  // namespace plexus::test
