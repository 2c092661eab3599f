// The daemon's answers to control requests: open/close ports, connect, stats, look-ups.
#include <spdlog/spdlog.h>

#include "daemon.hpp"
#include "inlet_counters.hpp"
#include "net/link.hpp"
#include "net/session.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/port_name.hpp"
#include "request_fields.hpp"
#include "script_host.hpp"

namespace plexus::daemon {

namespace {

using proto::ReplyCode;
constexpr auto peer_timeout = std::chrono::seconds(5);

}  // namespace

Task<proto::Reply> Daemon::handle(std::shared_ptr<Session> session, proto::Request request) {
    const std::string op = request.body["op"];
    const bool from_client = session->role() == "client";
    if (op == "open" && from_client)
        co_return co_await open_port(session, request);
    if (op == "close" && from_client)
        co_return co_await close_port(session, request);
    if (op == "attach" && session->role() == "link")
        co_return co_await attach(session, request);
    if (op == "connect")
        co_return co_await connect(request);
    if (op == "disconnect")
        co_return co_await disconnect(request);
    if (op == "stats")
        co_return co_await stats(request);
    if (op == "shm" && from_client)
        co_return co_await shm(session, request);
    if (op == "param")
        co_return co_await param(request);
    if (op == "param_recv")
        co_return co_await param_recv(request);
    if (op == "ping")
        co_return co_await ping(request);
    if (op == "events")
        co_return co_await events(request);
    if (op == "node")
        co_return ok({{"node", config_.node}, {"address", address()}, {"names", config_.names.text()}});
    if (op == "lookup" || op == "list") {
        nlohmann::json question = {{"op", op}, {"port", text(request.body, "port")}};
        co_return co_await ask_names(request, question);
    }
    co_return refuse("unknown request '" + op + "' for a " + session->role() + " session", ReplyCode::usage);
}

Task<proto::Reply> Daemon::ask_names(const proto::Request&, nlohmann::json body) {
    co_return relay(co_await names_->request(std::move(body)));
}

Task<proto::Reply> Daemon::open_port(std::shared_ptr<Session> session, const proto::Request& request) {
    const std::string name = text(request.body, "port");
    const auto policy = parse_queue_policy(request.body.value("policy", std::string("strict")));
    if (!policy)
        co_return refuse("queue policy must be 'strict' or 'latest'", ReplyCode::usage);
    const std::size_t capacity = request.body.value("capacity", config_.default_capacity);
    auto opened = router_.open(name, session->id(), *policy, capacity, config_.queue_bytes);
    if (!opened)
        co_return refuse(opened.error().message);
    auto port = *opened;
    auto registered = co_await names_->register_port(name);
    if (!registered || session->closed()) {
        router_.close(name);
        if (!registered)
            co_return refuse("cannot register " + name + ": " + registered.error().message);
        co_return refuse("the client went away while " + name + " was being registered");
    }
    const std::uint64_t handle = session->next_handle++;
    session->ports[handle] = port;
    std::weak_ptr<Session> weak = session;
    port->on_readable = [weak] {
        if (auto s = weak.lock())
            s->wake();
    };
    session->outbox().add_source({handle, &port->queue(), &port->delivered, port});
    spdlog::info("port {} opened ({} queue of {})", name, queue_policy_name(*policy), capacity);
    // Restore remembered connections before answering, so the client's first write already
    // flows along them.
    co_await restore_persistent(std::move(*registered));
    co_return ok({{"handle", handle}, {"node", config_.node}});
}

Task<proto::Reply> Daemon::close_port(std::shared_ptr<Session> session, const proto::Request& request) {
    const std::uint64_t handle = request.body.value("handle", std::uint64_t{0});
    auto it = session->ports.find(handle);
    if (it == session->ports.end())
        co_return refuse("no open port with handle " + std::to_string(handle));
    auto port = it->second;
    session->ports.erase(it);
    session->outbox().remove_source(handle);
    session->shm_regions.erase(handle);
    forget_port(port);
    co_return ok();
}

Task<proto::Reply> Daemon::shm(std::shared_ptr<Session> session, const proto::Request& request) {
    if (config_.shm_region_bytes == 0)
        co_return refuse("shared memory is off on this daemon (shm_region_bytes is 0)");
    if (!session->is_local())
        co_return refuse("shared memory needs a client on this machine (the Unix socket)");
    session->maps_shm = true;
    if (!request.body.contains("handle"))
        co_return ok();
    const std::uint64_t handle = request.body.value("handle", std::uint64_t{0});
    const std::uint64_t payload = request.body.value("bytes", std::uint64_t{0});  // before any change
    if (!session->ports.contains(handle))
        co_return refuse("no open port with handle " + std::to_string(handle));
    if (const auto known = session->shm_regions.find(handle); known != session->shm_regions.end())
        co_return ok({{"region", known->second->id()}, {"size", known->second->size()}});
    // Room for a few of the payload the client is about to write, however large it is (up to the
    // frame limit, which the copy-out path needs), and never less than the configured size.
    constexpr std::size_t payloads_per_region = 4;
    constexpr std::size_t granule = 1024 * 1024;
    const std::size_t capped = std::min<std::uint64_t>(payload, config_.max_frame);
    const std::size_t wanted = (capped * payloads_per_region + granule - 1) / granule * granule;
    const std::size_t size = std::max(config_.shm_region_bytes, wanted);
    if (shm_usage_->bytes + size > config_.shm_total_bytes) {
        co_return refuse("the daemon's shared memory is used up (shm_total_bytes " +
                         std::to_string(config_.shm_total_bytes) + ")");
    }
    auto created = ShmRegion::create(next_region_++, size, session, shm_usage_);
    if (!created) {
        spdlog::warn("no shared-memory region for {}: {}", session->description(), created.error().message);
        co_return refuse("no shared-memory region: " + created.error().message);
    }
    const auto region = *created;
    session->shm_regions.emplace(handle, region);
    // Before the reply, so the client has the region when it learns its id.
    session->outbox().push_writer_region(region);
    session->wake();
    co_return ok({{"region", region->id()}, {"size", region->size()}});
}

Task<proto::Reply> Daemon::connect(const proto::Request& request) {
    const std::string source = text(request.body, "source");
    const std::string destination = text(request.body, "destination");
    std::string carrier_text = text(request.body, "carrier");
    for (const auto& name : {source, destination}) {
        if (auto error = proto::port_name_error(name))
            co_return refuse(*error, ReplyCode::usage);
    }
    bool automatic = carrier_text.empty();
    proto::Carrier carrier;
    if (!automatic) {
        auto parsed = proto::parse_carrier(carrier_text);
        if (!parsed)
            co_return refuse("bad carrier: " + parsed.error().message);
        if (auto valid = proto::validate_carrier(*parsed); !valid)
            co_return refuse(valid.error().message);
        carrier = std::move(*parsed);
        carrier_text = carrier.text();
    }
    auto port = router_.find(source);
    if (!port)
        co_return co_await forward(request, source);
    // The send-side monitors run here whatever the destination; made first, so that a script
    // that fails leaves nothing behind.
    auto send_chain = scripts_->build_chain(carrier, proto::Side::send, source, destination);
    if (!send_chain)
        co_return refuse(send_chain.error().message);

    auto local_destination = router_.find(destination);
    const bool wants_tcp = !automatic && carrier_text.rfind("tcp", 0) == 0;
    const bool wants_local = !automatic && carrier_text.rfind("local", 0) == 0;
    if (local_destination && !wants_tcp) {
        auto member = new_member(local_destination, source, carrier);
        if (!member)
            co_return refuse(member.error().message);
        auto recv_chain = scripts_->build_chain(carrier, proto::Side::recv, source, destination, *member);
        if (!recv_chain)
            co_return refuse(recv_chain.error().message);
        auto warnings = check_member(*local_destination, **member, request.body.value("strict", false));
        if (!warnings)
            co_return refuse(warnings.error().message);
        auto connection = std::make_shared<Connection>();
        connection->source = source;
        connection->destination = destination;
        connection->carrier = automatic ? "local" : carrier_text;
        auto inlet = std::make_shared<Inlet>(local_destination, source, connection->carrier, *member);
        inlet->chain = std::move(*recv_chain);
        connection->sink = inlet;
        connection->send_chain = std::move(*send_chain);
        if (auto added = router_.add(port, connection); !added)
            co_return refuse(added.error().message);
        // Connections that were removed leave expired entries: drop them as new ones come.
        std::erase_if(local_destination->inbound,
                      [](const std::weak_ptr<Inlet>& entry) { return entry.expired(); });
        local_destination->inbound.push_back(inlet);
        local_destination->arbiter->join(**member);
        names::ConnectionEntry entry{source, destination, connection->carrier,
                                     request.body.value("persist", false)};
        co_await names_->add_connection(std::move(entry));
        spdlog::info("connected {} -> {} ({})", source, destination, connection->carrier);
        co_return ok({{"carrier", connection->carrier}, {"warnings", *warnings}});
    }
    if (wants_local) {
        co_return refuse("carrier 'local' needs both ports on one daemon, and " + destination +
                         " is not on this one");
    }
    std::string where;
    if (local_destination) {
        where = address();
    } else {
        auto found = co_await names_->lookup(destination);
        if (!found)
            co_return refuse(found.error().message);
        where = found->address;
    }
    std::string chosen = carrier_text;
    if (automatic)
        chosen = "tcp";
    std::shared_ptr<monitor::MonitorChain> chain = std::move(*send_chain);
    co_return co_await connect_remote(request, port, destination, chosen, where, chain);
}

Task<proto::Reply> Daemon::connect_remote(const proto::Request& request, std::shared_ptr<Port> port,
                                          std::string destination, std::string carrier, std::string address,
                                          std::shared_ptr<monitor::MonitorChain> send_chain) {
    const std::string source = port->name();
    for (const auto& existing : port->outgoing) {
        if (existing->destination == destination)
            co_return refuse("ports " + source + " and " + destination + " are already connected");
    }
    auto endpoint = proto::parse_endpoint(address);
    if (!endpoint)
        co_return refuse("the name server gave a bad address for " + destination + ": " + address);
    const proto::Hello hello = our_hello("link");
    auto peer = co_await Peer::connect(io_.get_executor(), *endpoint, hello, config_.max_frame, peer_timeout,
                                       space_notifier());
    if (!peer)
        co_return refuse("cannot reach the daemon of " + destination + ": " + peer.error().message);
    auto link_peer = *peer;
    link_peer->set_description("link " + source + " -> " + destination);
    nlohmann::json body4 = {{"op", "attach"},
                            {"source", source},
                            {"destination", destination},
                            {"carrier", carrier},
                            {"strict", request.body.value("strict", false)}};
    auto attached = co_await link_peer->request(body4, peer_timeout);
    if (!attached || attached->code != ReplyCode::ok) {
        link_peer->close("attach refused");
        co_return attached ? *attached : refuse(attached.error().message);
    }
    if (port->closed()) {
        link_peer->close("source closed");
        co_return refuse("port " + source + " closed while connecting");
    }
    auto link = std::make_shared<Link>(link_peer, config_.link_capacity, config_.queue_bytes);
    auto connection = std::make_shared<Connection>();
    connection->source = source;
    connection->destination = destination;
    connection->carrier = carrier;
    connection->remote = true;
    connection->sink = link;
    connection->send_chain = std::move(send_chain);
    if (auto added = router_.add(port, connection); !added) {
        link_peer->close("duplicate");
        co_return refuse(added.error().message);
    }
    links_.push_back(link_peer);
    std::weak_ptr<Connection> weak = connection;
    // The queue is held here, not reached through the connection: after a disconnect the
    // connection is gone while the link still drains, and what it could not send must be counted.
    link_peer->closed_handler = [this, weak, queue = link->queue(), source,
                                 destination](const std::string& reason) {
        if (queue->depth() > 0) {
            counters_.dropped_link_down += queue->depth();
            spdlog::warn("connection {} -> {} lost {} queued messages: {}", source, destination,
                         queue->depth(), reason);
        }
        auto c = weak.lock();
        if (!c)
            return;
        if (router_.remove(c)) {
            spdlog::info("connection {} -> {} went down: {}", c->source, c->destination, reason);
            notify_space();
            if (!stopping_)
                names_->notify_connection_down(c->source, c->destination);
        }
    };
    names::ConnectionEntry entry{source, destination, carrier, request.body.value("persist", false)};
    co_await names_->add_connection(std::move(entry));
    spdlog::info("connected {} -> {} ({} to {})", source, destination, carrier, address);
    co_return ok(
        {{"carrier", carrier}, {"warnings", attached->body.value("warnings", nlohmann::json::array())}});
}

Task<proto::Reply> Daemon::attach(std::shared_ptr<Session> session, const proto::Request& request) {
    const std::string destination = text(request.body, "destination");
    auto port = router_.find(destination);
    if (!port)
        co_return refuse("port " + destination + " does not exist on node '" + config_.node + "'");
    if (session->is_link())
        co_return refuse("this link is already attached", ReplyCode::usage);
    const std::string source = text(request.body, "source");
    if (auto error = proto::port_name_error(source))
        co_return refuse(*error, ReplyCode::usage);
    auto carrier = proto::parse_carrier(text(request.body, "carrier"));
    if (!carrier)
        co_return refuse("bad carrier: " + carrier.error().message);
    if (auto valid = proto::validate_carrier(*carrier); !valid)
        co_return refuse(valid.error().message);
    auto member = new_member(port, source, *carrier);
    if (!member)
        co_return refuse(member.error().message);
    auto recv_chain = scripts_->build_chain(*carrier, proto::Side::recv, source, destination, *member);
    if (!recv_chain)
        co_return refuse(recv_chain.error().message);
    auto warnings = check_member(*port, **member, request.body.value("strict", false));
    if (!warnings)
        co_return refuse(warnings.error().message);
    auto link = std::make_shared<Inlet>(port, source, carrier->text(), *member);
    link->chain = std::move(*recv_chain);
    std::erase_if(port->inbound, [](const std::weak_ptr<Inlet>& inlet) { return inlet.expired(); });
    port->inbound.push_back(link);
    port->arbiter->join(**member);
    session->become_link(link);
    std::weak_ptr<Session> weak = session;
    port->on_close(weak, [weak] {
        if (auto s = weak.lock())
            s->close("destination port closed");
    });
    session->set_description("link " + source + " -> " + destination);
    co_return ok({{"warnings", *warnings}});
}

Task<proto::Reply> Daemon::disconnect(const proto::Request& request) {
    const std::string source = text(request.body, "source");
    const std::string destination = text(request.body, "destination");
    if (!router_.find(source))
        co_return co_await forward(request, source);
    auto removed = router_.remove(source, destination);
    if (!removed)
        co_return refuse("ports " + source + " and " + destination + " are not connected", ReplyCode::no);
    notify_space();
    co_await names_->remove_connection(source, destination, true);
    spdlog::info("disconnected {} -> {}", source, destination);
    co_return ok();
}

Task<proto::Reply> Daemon::stats(const proto::Request& request) {
    const std::string port = text(request.body, "port");
    if (!port.empty() && !router_.find(port))
        co_return co_await forward(request, port);
    co_return ok(stats_json(port));
}

Task<proto::Reply> Daemon::ping(const proto::Request& request) {
    const std::string port = text(request.body, "port");
    if (port.empty() || router_.find(port))
        co_return ok({{"node", config_.node}, {"address", address()}});
    co_return co_await forward(request, port);
}

Task<proto::Reply> Daemon::forward(const proto::Request& request, const std::string& port) {
    if (request.body.value("forwarded", false))
        co_return refuse("port " + port + " is not on node '" + config_.node + "'");
    auto found = co_await names_->lookup(port);
    if (!found)
        co_return refuse(found.error().message);
    const std::string where = found->address;
    auto endpoint = proto::parse_endpoint(where);
    if (!endpoint)
        co_return refuse("the name server gave a bad address for " + port + ": " + where);
    const proto::Hello hello = our_hello("daemon");
    auto peer = co_await Peer::connect(io_.get_executor(), *endpoint, hello, config_.max_frame, peer_timeout,
                                       std::function<void()>{});
    if (!peer)
        co_return refuse("cannot reach the daemon of " + port + ": " + peer.error().message);
    auto body = request.body;
    body["forwarded"] = true;
    auto reply = co_await (*peer)->request(body, peer_timeout);
    (*peer)->close_when_drained();
    co_return relay(reply);
}

Task<void> Daemon::restore_persistent(std::vector<names::ConnectionEntry> persistent) {
    for (const auto& entry : persistent) {
        proto::Request request;
        request.body = {{"op", "connect"},
                        {"source", entry.source},
                        {"destination", entry.destination},
                        {"carrier", entry.carrier}};
        // Either end may come up first; the one that comes second makes the connection, so a
        // failure here (the other end is not there yet) is expected and only logged.
        auto reply = co_await connect(request);
        if (reply.code == ReplyCode::ok) {
            spdlog::info("restored persistent connection {} -> {}", request.body["source"].get<std::string>(),
                         request.body["destination"].get<std::string>());
        } else {
            spdlog::debug("persistent connection {} -> {} not restored yet: {}",
                          request.body["source"].get<std::string>(),
                          request.body["destination"].get<std::string>(),
                          reply.body.value("error", std::string{}));
        }
    }
}

nlohmann::json Daemon::stats_json(const std::string& only_port) const {
    nlohmann::json ports = nlohmann::json::array();
    for (const auto& [name, port] : router_.ports()) {
        if (!only_port.empty() && name != only_port)
            continue;
        nlohmann::json connections = nlohmann::json::array();
        for (const auto& c : port->outgoing) {
            nlohmann::json entry{{"destination", c->destination},
                                 {"carrier", c->carrier},
                                 {"sent", c->sent},
                                 {"dropped_by_monitor", c->dropped_by_monitor}};
            if (c->remote)
                entry["queued"] = static_cast<const Link*>(c->sink.get())->queued();
            if (c->send_chain)
                entry["monitors"] = c->send_chain->stats();
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
            if (inlet->chain)
                entry["monitors"] = inlet->chain->stats();
            inbound.push_back(entry);
        }
        const auto& queue = port->queue();
        ports.push_back({{"name", name},
                         {"policy", queue_policy_name(queue.policy())},
                         {"capacity", queue.capacity()},
                         {"bytes", queue.bytes()},
                         {"depth", queue.depth()},
                         {"written", port->written},
                         {"received", port->received},
                         {"delivered", port->delivered},
                         {"dropped_queue", queue.dropped()},
                         {"outgoing", connections},
                         {"inbound", inbound}});
    }
    return {{"node", config_.node},
            {"address", address()},
            {"ports", ports},
            {"daemon",
             {{"sessions", sessions_.size()},
              {"sessions_accepted", counters_.sessions_accepted},
              {"accept_errors", counters_.accept_errors},
              {"protocol_errors", counters_.protocol_errors},
              {"dropped_unknown_port", counters_.dropped_unknown_port},
              {"dropped_link_down", counters_.dropped_link_down},
              {"shm_passed", counters_.shm_passed},
              {"shm_copied", counters_.shm_copied},
              {"shm_regions", shm_usage_->regions},
              {"shm_bytes", shm_usage_->bytes},
              {"shm_slots", shm_usage_->slots},
              {"monitor_published", scripts_->published()},
              {"monitor_publish_dropped", scripts_->publish_dropped()}}}};
}

}  // namespace plexus::daemon
