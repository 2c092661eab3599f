#include "stats_view.hpp"

#include "control/monitor_wiring.hpp"
#include "core/router.hpp"
#include "inlet_counters.hpp"
#include "monitor/stage.hpp"
#include "net/call_table.hpp"
#include "net/udp_socket.hpp"

namespace plexus::daemon::inspect {

namespace {

/// A monitored side's counters: its monitors', and where they run (monitor/stage.hpp).
void add_stage_counters(nlohmann::json& entry, const monitor::MonitorStage& stage) {
    entry["monitors"] = stage.chain().stats();
    entry["dropped_monitor_backlog"] = stage.dropped_backlog();
    entry["monitors_inline"] = stage.runs_inline();
    entry["monitor_inline_overruns"] = stage.inline_overruns();
    entry["monitor_cost_seconds"] = stage.cost_histogram().to_json();
}

}  // namespace

nlohmann::json stats_view(ControlHost& host, const ShmUsage& shm, const std::string& only_port) {
    nlohmann::json ports = nlohmann::json::array();
    for (const auto& [name, port] : host.router().ports()) {
        if (!only_port.empty() && name != only_port)
            continue;
        nlohmann::json connections = nlohmann::json::array();
        for (const auto& c : port->outgoing) {
            nlohmann::json entry{{"destination", c->destination},
                                 {"carrier", c->carrier},
                                 {"sent", c->sent},
                                 {"dropped_by_monitor", c->dropped_by_monitor},
                                 {"dropped_by_route", c->dropped_by_route},
                                 {"calls", c->calls}};
            // What the carrier's sending end counts itself (a tcp link's queue, udp's or mcast's
            // datagrams), and the monitors it runs for the whole port (mcast's shared ones).
            c->sink->report_stats(entry);
            if (const auto* stage = monitor::stage_of(c->sink->shared_send_stage()))
                entry["monitors"] = stage->chain().stats();
            if (const auto* stage = monitor::stage_of(c->send_monitors)) {
                add_stage_counters(entry, *stage);
            }
            connections.push_back(entry);
        }
        nlohmann::json inbound = nlohmann::json::array();
        for (const auto& weak : port->inbound) {
            auto inlet = weak.lock();
            if (!inlet)
                continue;
            nlohmann::json entry = inlet_counters(*inlet);
            entry["source"] = inlet->source();
            entry["carrier"] = inlet->carrier();
            if (const auto* stage = monitor::stage_of(inlet->monitors)) {
                add_stage_counters(entry, *stage);
            }
            inbound.push_back(entry);
        }
        const auto& queue = port->queue();
        ports.push_back({{"name", name},
                         {"policy", queue_policy_name(queue.policy())},
                         {"capacity", queue.capacity()},
                         {"bytes", queue.bytes()},
                         {"depth", queue.depth()},
                         {"written", port->written},
                         {"unconnected", port->unconnected},
                         {"received", port->received},
                         {"delivered", port->delivered},
                         {"dropped_queue", queue.dropped()},
                         {"served", port->served},
                         {"calls_outstanding", port->calls_outstanding},
                         {"calls_refused", port->calls_refused},
                         {"reported", port->reported},
                         {"outgoing", connections},
                         {"inbound", inbound}});
    }
    const auto counters = host.total_counters();
    const auto& scripts = host.scripts();
    nlohmann::json view{{"node", host.config().node},
                        {"address", host.address()},
                        {"ports", ports},
                        {"daemon",
                         {{"sessions", host.session_count()},
                          {"sessions_accepted", counters.sessions_accepted},
                          {"accept_errors", counters.accept_errors},
                          {"protocol_errors", counters.protocol_errors},
                          {"auth_failures", counters.auth_failures},
                          {"handshake_timeouts", counters.handshake_timeouts},
                          {"peers_refused", counters.peers_refused},
                          {"tls_records_refused", counters.tls_records_refused},
                          {"permission_refusals", counters.permission_refusals},
                          {"dropped_unknown_port", counters.dropped_unknown_port},
                          {"dropped_link_down", counters.dropped_link_down},
                          {"shm_passed", counters.shm_passed},
                          {"shm_copied", counters.shm_copied},
                          {"shm_regions", shm.regions.load()},
                          {"shm_bytes", shm.bytes.load()},
                          {"shm_slots", shm.slots.load()},
                          {"ring_sessions", counters.ring_sessions},
                          {"rings_refused", counters.rings_refused},
                          {"udp_datagrams_sent", host.udp().counters().datagrams_sent},
                          {"udp_datagrams_received", host.udp().counters().datagrams_received},
                          {"udp_bad_datagrams", host.udp().counters().bad_datagrams},
                          {"udp_unknown_stream", host.udp().counters().unknown_stream},
                          {"udp_wrong_sender", host.udp().counters().wrong_sender},
                          {"udp_send_failures", host.udp().counters().send_failures},
                          {"udp_bad_mac", host.udp().counters().bad_mac},
                          {"udp_reassembly_bytes", host.udp().budget().bytes},
                          {"monitor_published", scripts.published()},
                          {"monitor_publish_dropped", scripts.publish_dropped()}}}};
    host.calls().add_stats(view["daemon"]);
    if (auto http = host.http_counters(); !http.is_null())
        view["http"] = std::move(http);  // the web endpoint's, when it serves one (docs/WEB.md)
    return view;
}

}  // namespace plexus::daemon::inspect
