// What the web endpoint makes of the daemon's documents: Prometheus text from a stats document,
// Server-Sent Events, message summaries, histograms.
#include <gtest/gtest.h>

#include "core/latency_histogram.hpp"
#include "core/message_sampler.hpp"
#include "plexus/proto/cbor.hpp"
#include "web/event_stream.hpp"
#include "web/metrics.hpp"

namespace plexus::daemon {
namespace {

using nlohmann::json;

proto::Bytes cbor(const json& value) {
    proto::Bytes out;
    proto::encode_cbor(value, out);
    return out;
}

TEST(WebMetrics_test, EveryNumberOfStatsIsAMetricWithItsLabels) {
    LatencyHistogram cost;
    cost.observe(3e-6, 4);
    cost.observe(2e-3);
    const json stats{{"node", "n1"},
                     {"daemon", {{"sessions", 3}, {"protocol_errors", 2}}},
                     {"ports",
                      {{{"name", "/a\"b"},
                        {"policy", "latest"},
                        {"depth", 1},
                        {"written", 10},
                        {"outgoing", {{{"destination", "/c"}, {"carrier", "tcp"}, {"sent", 7}}}},
                        {"inbound",
                         {{{"source", "/d"},
                           {"received", 5},
                           {"monitors_inline", true},
                           {"monitor_cost_seconds", cost.to_json()},
                           {"monitors",
                            {{{"script", "certainty"},
                              {"type", "lua"},
                              {"side", "recv"},
                              {"dropped", 2},
                              {"quarantined", false},
                              {"last_error", "x"}}}}}}}}}}};
    web::HttpCounters http;
    http.count(web::Refused::token);
    const std::string text = web::metrics_text(stats, http);
    for (const char* line : {
             "plexus_daemon_sessions{node=\"n1\"} 3\n",
             "plexus_daemon_protocol_errors_total{node=\"n1\"} 2\n",
             "plexus_port_depth{node=\"n1\",port=\"/a\\\"b\"} 1\n",
             "plexus_port_written_total{node=\"n1\",port=\"/a\\\"b\"} 10\n",
             "plexus_outgoing_sent_total{node=\"n1\",port=\"/a\\\"b\",destination=\"/c\"} 7\n",
             "plexus_inbound_received_total{node=\"n1\",port=\"/a\\\"b\",source=\"/d\"} 5\n",
             "plexus_inbound_monitors_inline{node=\"n1\",port=\"/a\\\"b\",source=\"/d\"} 1\n",
             "plexus_monitor_dropped_total{node=\"n1\",port=\"/a\\\"b\",source=\"/"
             "d\",side=\"recv\",script=\"certainty\","
             "type=\"lua\"} 2\n",
             "plexus_monitor_quarantined{node=\"n1\",port=\"/a\\\"b\",source=\"/"
             "d\",side=\"recv\",script=\"certainty\","
             "type=\"lua\"} 0\n",
             "plexus_monitor_cost_seconds_bucket{node=\"n1\",port=\"/a\\\"b\",source=\"/d\",le=\"2.5e-06\"} "
             "0\n",
             "plexus_monitor_cost_seconds_bucket{node=\"n1\",port=\"/a\\\"b\",source=\"/d\",le=\"5e-06\"} "
             "4\n",
             "plexus_monitor_cost_seconds_bucket{node=\"n1\",port=\"/a\\\"b\",source=\"/d\",le=\"+Inf\"} 5\n",
             "plexus_monitor_cost_seconds_count{node=\"n1\",port=\"/a\\\"b\",source=\"/d\"} 5\n",
             "plexus_http_refused_total{node=\"n1\",reason=\"token\"} 1\n",
             "# TYPE plexus_port_written_total counter\n",
             "# TYPE plexus_monitor_cost_seconds histogram\n",
         }) {
        EXPECT_NE(text.find(line), std::string::npos) << line << "\nin:\n" << text;
    }
    EXPECT_EQ(text.find("last_error"), std::string::npos);  // text is not a number
    EXPECT_EQ(text.find("policy"), std::string::npos);
    // One TYPE line per family, even with samples of several ports.
    EXPECT_EQ(text.find("# TYPE plexus_monitor_cost_seconds histogram"),
              text.rfind("# TYPE plexus_monitor_cost_seconds histogram"));
}

TEST(WebStream_test, AnEventIsOneDataLine) {
    EXPECT_EQ(web::sse_event("arbitration", {{"t", 1}, {"text", "a\nb"}}),
              "event: arbitration\ndata: {\"t\":1,\"text\":\"a\\nb\"}\n\n");
}

TEST(MessageSampler_test, SummarisesBlobsAndLargePayloads) {
    const auto small = cbor(json{{"x", 1}, {"image", json::binary({1, 2, 3, 4, 5})}});
    const auto summary = summarise_payload(small);
    EXPECT_EQ(summary["x"], 1);
    EXPECT_EQ(summary["image"], (json{{"blob", 5}, {"type", "blob"}}));
    const auto large = cbor(json::array({std::string(5000, 'a')}));
    EXPECT_EQ(summarise_payload(large)["truncated"], large.size());
    const std::uint8_t garbage[] = {0xff, 0x00};
    EXPECT_EQ(summarise_payload(garbage)["undecodable"], 2);
}

TEST(LatencyHistogram_test, CountsEachObservationInTheFirstBucketThatHoldsIt) {
    LatencyHistogram histogram;
    histogram.observe(1e-6);    // on a bound: that bucket
    histogram.observe(1.1e-6);  // the next
    histogram.observe(1.0, 3);  // beyond every bound: +Inf
    const auto view = histogram.to_json();
    EXPECT_EQ(view["counts"][0], 1);
    EXPECT_EQ(view["counts"][1], 1);
    EXPECT_EQ(view["counts"][LatencyHistogram::bounds.size()], 3);
    EXPECT_EQ(view["count"], 5);
    EXPECT_DOUBLE_EQ(view["sum"].get<double>(), 1e-6 + 1.1e-6 + 3.0);
}

}  // namespace
}  // namespace plexus::daemon
