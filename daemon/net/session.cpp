#include "session.hpp"

#include <spdlog/spdlog.h>

#include <cstdlib>

#include "../core/batch.hpp"
#include "../core/call_routing.hpp"
#include "../core/router.hpp"
#include "call_table.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/rings.hpp"
#include "plexus/proto/shm.hpp"
#include "session_host.hpp"

namespace plexus::daemon {

namespace {
/// Requests one session may have in progress at once (see Session::requests_in_flight_).
constexpr std::size_t max_requests_in_flight = 64;
/// Reply bytes the peer has not taken yet beyond which no further request is read.
constexpr std::size_t max_unread_replies = 4u * 1024u * 1024u;
bool is_data(proto::FrameType type) {
    return type == proto::FrameType::data || type == proto::FrameType::data_batch ||
           type == proto::FrameType::data_shm;
}
}  // namespace

Session::Session(Socket socket, SessionHost& daemon, std::uint64_t id, std::size_t shard)
    : FramedConnection(std::move(socket), daemon.config().max_frame, [&daemon] { daemon.notify_space(); }),
      daemon_(daemon),
      id_(id),
      shard_(shard),
      request_done_(executor()) {
    // Counted on this session's thread, in that thread's counters.
    outbox().on_shm_copy([&daemon] { ++daemon.counters().shm_copied; });
}

proto::Status Session::on_hello(const proto::Hello& hello) {
    if (hello.role != "client" && hello.role != "daemon" && hello.role != "link") {
        return proto::Error{"unknown role '" + hello.role + "' (expected client, daemon or link)"};
    }
    role_ = hello.role;
    return proto::Ok{};
}

std::uint64_t Session::add_port(std::shared_ptr<Port> port) {
    const std::uint64_t handle = next_handle_++;
    ports_[handle] = port;
    std::weak_ptr<FramedConnection> weak = weak_from_this();
    port->on_readable = [weak] {
        if (auto s = weak.lock())
            s->wake();
    };
    const Port* raw = port.get();  // kept alive by the source's keep_alive
    outbox().add_source({handle, &port->queue(), &port->delivered, port, [raw] { return raw->priority(); }});
    return handle;
}

std::shared_ptr<Port> Session::take_port(std::uint64_t handle) {
    auto it = ports_.find(handle);
    if (it == ports_.end())
        return nullptr;
    auto port = std::move(it->second);
    ports_.erase(it);
    outbox().remove_source(handle);
    shm_regions_.erase(handle);
    return port;
}

std::vector<std::shared_ptr<Port>> Session::take_ports() {
    std::vector<std::shared_ptr<Port>> ports;
    for (auto& [handle, port] : ports_)
        ports.push_back(std::move(port));
    ports_.clear();
    return ports;
}

std::shared_ptr<ShmRegion> Session::shm_region(std::uint64_t handle) const {
    const auto it = shm_regions_.find(handle);
    return it == shm_regions_.end() ? nullptr : it->second;
}

void Session::add_shm_region(std::uint64_t handle, std::shared_ptr<ShmRegion> region) {
    shm_regions_.emplace(handle, region);
    outbox().push_writer_region(region);
    wake();
}

void Session::become_link(std::shared_ptr<Inlet> link) {
    link_port_ = link->port();
    link_ = std::move(link);
}

Task<bool> Session::on_frame(InFrame frame) {
    switch (frame.type) {
        case proto::FrameType::data:
        case proto::FrameType::data_batch:
        case proto::FrameType::data_shm:
            co_return co_await on_data(std::move(frame));
        case proto::FrameType::shm_release:
            co_return on_release(frame);
        case proto::FrameType::call:
        case proto::FrameType::answer:
            co_return co_await asio::co_spawn(daemon_.control_executor(), on_call_frame(std::move(frame)),
                                              asio::use_awaitable);
        case proto::FrameType::request: {
            auto request = proto::decode_request(frame.fields);
            if (!request) {
                ++daemon_.counters().protocol_errors;
                fail("bad request: " + request.error().message);
                co_return false;
            }
            // Requests may wait on other daemons: serve each on its own coroutine so data keeps
            // flowing, but only so many at once, and none while the peer leaves its replies unread.
            while (requests_in_flight_ >= max_requests_in_flight ||
                   outbox().control_bytes() > max_unread_replies) {
                constexpr auto recheck = std::chrono::milliseconds(100);
                co_await request_done_.wait_for(recheck);
                if (closed())
                    co_return false;
            }
            ++requests_in_flight_;
            auto self = std::static_pointer_cast<Session>(shared_from_this());
            asio::co_spawn(
                executor(), [self, r = std::move(*request)]() mutable { return self->serve(std::move(r)); },
                asio::detached);
            co_return true;
        }
        default:
            ++daemon_.counters().protocol_errors;
            fail("unexpected " + proto::frame_type_name(static_cast<std::uint8_t>(frame.type)) + " frame");
            co_return false;
    }
}

Task<void> Session::serve(proto::Request request) {
    auto self = std::static_pointer_cast<Session>(shared_from_this());
    const auto id = request.id;
    proto::Reply reply;
    try {
        if (shard_ == 0)
            reply = co_await daemon_.handle_request(self, std::move(request));
        else
            reply = co_await asio::co_spawn(daemon_.control_executor(),
                                            daemon_.handle_request(self, std::move(request)),
                                            asio::use_awaitable);
    } catch (const std::exception& e) {
        // A malformed field (wrong JSON type) must not take the daemon down: refuse the request.
        reply =
            proto::make_refusal(id, proto::ReplyCode::usage, std::string("malformed request: ") + e.what());
    }
    reply.id = id;
    send(proto::encode_reply(reply));
    --requests_in_flight_;
    request_done_.notify();
}

std::optional<Session::Incoming> Session::decode_incoming(InFrame& frame) {
    if (frame.type == proto::FrameType::data_shm)
        return decode_shm(frame);
    if (frame.type == proto::FrameType::data) {
        auto data = proto::decode_data(frame.fields);
        if (!data) {
            ++daemon_.counters().protocol_errors;
            fail("bad data frame: " + data.error().message);
            return std::nullopt;
        }
        return Incoming{data->handle, Message{frame.storage, data->record, 0, 0}};
    }
    auto batch = proto::decode_batch(frame.fields);
    if (!batch) {
        ++daemon_.counters().protocol_errors;
        fail(batch.error().message);
        return std::nullopt;
    }
    Message message{frame.storage, batch->records, 0, static_cast<std::uint32_t>(batch->count)};
    if (frame.delivered_records > 0)
        message = without_first_records(message, frame.delivered_records);
    return Incoming{batch->handle, std::move(message)};
}

std::optional<Session::Incoming> Session::decode_shm(InFrame& frame) {
    auto data = proto::decode_shm_data(frame.fields);
    if (!data) {
        ++daemon_.counters().protocol_errors;
        fail("bad data_shm frame: " + data.error().message);
        return std::nullopt;
    }
    auto port = ports_.find(data->handle);
    if (port == ports_.end() && !link_port_) {
        // Written while its port was closing: counted as dropped by try_deliver, like a data frame.
        // The writer's region went with the port, so its slot needs no freeing.
        return Incoming{data->handle, Message{frame.storage, {}, 0, 0}};
    }
    if (!frame.resolved) {
        const auto region = shm_regions_.find(data->handle);
        if (link_port_ || region == shm_regions_.end() || !region->second ||
            region->second->id() != data->place.region) {
            ++daemon_.counters().protocol_errors;
            fail("data_shm for region " + std::to_string(data->place.region) +
                 ", which is not the region of handle " + std::to_string(data->handle));
            return std::nullopt;
        }
        if (!region->second->holds(data->place.offset, data->place.length)) {
            ++daemon_.counters().protocol_errors;
            fail("data_shm place " + std::to_string(data->place.offset) + "+" +
                 std::to_string(data->place.length) + " outside its region of " +
                 std::to_string(region->second->size()) + " bytes");
            return std::nullopt;
        }
        if (data->head.size() + data->place.length > daemon_.config().max_frame) {
            // Copied out, it would be a data frame no reader or link takes: refused as on the socket.
            ++daemon_.counters().protocol_errors;
            fail("data_shm payload of " + std::to_string(data->place.length) +
                 " bytes exceeds the frame limit " + std::to_string(daemon_.config().max_frame));
            return std::nullopt;
        }
        if (!check_sources(Message{frame.storage, data->head}, port->second->name(),
                           "written on the handle of"))
            return std::nullopt;
        // The slot is held from here on: whatever becomes of the message, its end frees the slot.
        frame.resolved =
            Message{frame.storage, data->place_and_head, 0, 0,
                    std::make_shared<const ShmSlot>(region->second, data->place.offset, data->place.length)};
    }
    // Judged again at every try: connections may change while the frame waits for room.
    if (frame.resolved->shm &&
        (!passes_shm(*port->second) || !frame.resolved->shm->region->seal_for_readers())) {
        frame.resolved = copy_out_of_shm(*frame.resolved);
        ++daemon_.counters().shm_copied;
    }
    return Incoming{data->handle, *frame.resolved};
}

bool Session::passes_shm(const Port& port) const {
    for (const auto& connection : port.outgoing) {
        // A reader on another of the daemon's threads is lent the payload too (the crossing copies
        // only the place); what is read here of it changes on the control thread alone.
        if (connection->remote || connection->send_monitors)
            return false;
        const auto* inlet = dynamic_cast<const Inlet*>(connection->sink.get());
        // A recorded port's tap keeps the payload: it is copied out once, as for monitors.
        if (!inlet || inlet->monitors || !inlet->member().trivial() || inlet->port()->tap)
            return false;
        const auto reader = daemon_.session(inlet->port()->owner());
        // A reader that holds too many regions already copies it out itself (Outbox::max_regions).
        if (!reader || !reader->maps_shm())
            return false;
    }
    return true;
}

bool Session::on_release(const InFrame& frame) {
    const auto count = proto::decode_shm_number(frame.fields, "count");
    if (!count || !outbox().release(*count)) {
        ++daemon_.counters().protocol_errors;
        fail(count ? "shm_release of " + std::to_string(*count) + " messages, but " +
                         std::to_string(outbox().lent()) + " were sent"
                   : "bad shm_release frame: " + count.error().message);
        return false;
    }
    return true;
}

bool Session::check_sources(const Message& message, const std::string& expected, std::string_view writer) {
    // Every record must be well formed and come from the port it is written for: a reader must
    // never see a record its writer could not have sent. The fast check passes good records at a
    // few nanoseconds each; only when it fails are they decoded one by one, to say what is wrong.
    proto::Bytes source_field;
    proto::append_string(source_field, expected);
    const bool fine = message.batch == 0
                          ? proto::record_from(message.record, source_field)
                          : proto::batch_records_from(message.record, message.batch, source_field);
    if (fine)
        return true;
    std::string problem;
    auto check = [&](proto::ByteView bytes) {
        auto record = proto::decode_record(bytes);
        if (!record) {
            problem = "bad message record: " + record.error().message;
        } else if (record->source != expected) {
            problem = "message from port '" + std::string(record->source) + "' " + std::string(writer) + " " +
                      expected;
        }
        return problem.empty();
    };
    if (message.batch == 0) {
        check(message.record);
    } else {
        proto::BatchRecords records(message.record, message.batch);
        while (const auto record = records.next()) {
            if (!check(*record))
                break;
        }
        if (problem.empty() && !records.error().empty())
            problem = records.error();
    }
    if (problem.empty())
        return true;
    ++daemon_.counters().protocol_errors;
    fail(problem);
    return false;
}

template <typename Deliver>
Session::DataOutcome Session::deliver_within(InFrame& frame, const Message& message, std::size_t room,
                                             Deliver deliver) {
    if (room == 0)
        return DataOutcome::blocked;
    if (message.count() <= room) {
        deliver(message);
        return DataOutcome::delivered;
    }
    // Only a batch can be larger than the room: deliver its head, keep the rest for later, so
    // that a strict queue's bound holds for batches as it does for single messages.
    const auto fits = static_cast<std::uint32_t>(room);
    deliver(first_records(message, fits));
    frame.delivered_records += fits;
    return DataOutcome::blocked;
}

Session::DataOutcome Session::try_deliver(InFrame& frame) {
    if (frame.type == proto::FrameType::data_shm && frees_pile_up())
        return DataOutcome::blocked;
    auto incoming = decode_incoming(frame);
    if (!incoming)
        return DataOutcome::stop;
    const Message& message = incoming->message;
    if (link_port_) {
        // The receiving end of a connection from another daemon: hold back while the reader is full,
        // so that TCP carries the back-pressure to the sending daemon.
        if (!check_sources(message, link_->source(), "on the link attached for"))
            return DataOutcome::stop;
        if (link_port_->closed() || closed())
            return DataOutcome::stop;
        return deliver_within(frame, message, link_->room(), [&](const Message& m) { link_->deliver(m); });
    }
    auto it = ports_.find(incoming->handle);
    if (it == ports_.end() || it->second->closed()) {
        // The client may write while its close is in flight; count it rather than cut it off.
        daemon_.counters().dropped_unknown_port += message.count();
        return DataOutcome::delivered;
    }
    Port& port = *it->second;
    if (!message.shm && !check_sources(message, port.name(), "written on the handle of"))
        return DataOutcome::stop;
    const auto outcome =
        deliver_within(frame, message, Router::room(port), [&](const Message& m) { Router::route(port, m); });
    if (outcome == DataOutcome::delivered && message.shm)
        ++daemon_.counters().shm_passed;
    return outcome;
}

bool Session::frees_pile_up() {
    // Every data_shm message, once done with, queues a shm_free frame for this session. A client
    // that writes them without reading its socket would make those frames pile up without bound:
    // it is not read any more until it has taken them, as for replies.
    constexpr std::size_t max_unread_frees = 1u << 16;  // a writer has at most a few hundred slots
    return outbox().control_bytes() > max_unread_replies || outbox().control_frames() > max_unread_frees;
}

FramedConnection::FrameAction Session::on_frame_now(InFrame& frame) {
    if (frame.type == proto::FrameType::shm_release)
        return on_release(frame) ? FrameAction::handled : FrameAction::stop;
    if (frame.type == proto::FrameType::rings)
        return on_rings(frame) ? FrameAction::handled : FrameAction::stop;
    // On a data thread calls and answers go to the control thread, by on_frame.
    if (frame.type == proto::FrameType::call && shard_ == 0)
        return on_call(frame) ? FrameAction::handled : FrameAction::stop;
    if (frame.type == proto::FrameType::answer && shard_ == 0)
        return on_answer(frame) ? FrameAction::handled : FrameAction::stop;
    if (!is_data(frame.type))
        return FrameAction::wait;
    switch (try_deliver(frame)) {
        case DataOutcome::delivered:
            return FrameAction::handled;
        case DataOutcome::stop:
            return FrameAction::stop;
        case DataOutcome::blocked:
            break;
    }
    return FrameAction::wait;
}

Task<bool> Session::on_call_frame(InFrame frame) {
    auto self = shared_from_this();  // kept while the control thread serves it
    co_return frame.type == proto::FrameType::call ? on_call(frame) : on_answer(frame);
}

Task<bool> Session::on_data(InFrame frame) {
    for (;;) {
        daemon_.expect_space();  // before looking: room that appears meanwhile must wake us
        switch (try_deliver(frame)) {
            case DataOutcome::delivered:
                co_return true;
            case DataOutcome::stop:
                co_return false;
            case DataOutcome::blocked:
                break;
        }
        co_await wait_for_space();
        if (closed())
            co_return false;
    }
}

namespace {
/// The configured spin, or PLEXUS_RING_SPIN_US's when the configuration has none (for experiments).
std::chrono::microseconds ring_spin(const NetConfig& config) {
    if (config.ring_spin.count() > 0)
        return config.ring_spin;
    static const std::chrono::microseconds from_environment = [] {
        const char* text = std::getenv("PLEXUS_RING_SPIN_US");
        const long us = text ? std::strtol(text, nullptr, 10) : 0;
        return std::chrono::microseconds(us > 0 && us <= 1000 ? us : 0);
    }();
    return from_environment;
}
}  // namespace

bool Session::on_rings(const InFrame& frame) {
    const auto wanted = proto::decode_rings_request(frame.fields);
    if (!wanted) {
        ++daemon_.counters().protocol_errors;
        fail("bad rings frame: " + wanted.error().message);
        return false;
    }
    if (rings()) {
        ++daemon_.counters().protocol_errors;
        fail("rings asked for twice");
        return false;
    }
    auto refuse = [&](const std::string& why) {
        ++daemon_.counters().rings_refused;
        spdlog::info("{}: rings refused: {}", description(), why);
        send(proto::make_rings_answer({0, why}));
        return true;
    };
    const std::size_t configured = daemon_.config().shm_ring_bytes;
    if (configured == 0)
        return refuse("shared-memory rings are off on this daemon (shm_ring_bytes is 0)");
    if (!is_local())
        return refuse("shared-memory rings are only for a client on the daemon's machine (a Unix socket)");
    // The client may ask for smaller rings than the daemon's, never larger ones.
    const std::size_t bytes =
        std::min(configured, proto::RingLayout::ring_bytes_for(*wanted ? *wanted : configured));
    auto rings = SessionRings::create(executor(), bytes);
    if (!rings)
        return refuse("cannot make the rings: " + rings.error().message);
    (*rings)->set_spin(ring_spin(daemon_.config()));
    if (!use_rings(std::move(*rings), proto::make_rings_answer({bytes, ""}))) {
        ++daemon_.counters().protocol_errors;
        return false;
    }
    ++daemon_.counters().ring_sessions;
    return true;
}

bool Session::on_call(const InFrame& frame) {
    const auto call = proto::decode_call(frame.fields);
    if (!call) {
        ++daemon_.counters().protocol_errors;
        fail("bad call frame: " + call.error().message);
        return false;
    }
    CallTable& calls = daemon_.calls();
    const Message request{frame.storage, call->record};
    const auto deadline = CallTicket::Clock::now() + std::chrono::milliseconds(call->timeout_ms);
    auto self = shared_from_this();
    if (link_port_) {
        // From the caller's daemon, on the link of one connection: into the served port, through
        // the connection's receiving monitors and the port's arbitration, as its data would go.
        if (!check_sources(request, link_->source(), "on the link attached for"))
            return false;
        if (link_port_->closed() || link_->room() == 0) {
            calls.refuse(*this, call->id,
                         "busy: " + link_port_->name() + " takes no more now (its queue is full)");
            return true;
        }
        auto ticket = calls.start(self, call->id, deadline, link_->source() + " -> " + link_port_->name(),
                                  link_port_, {link_->monitors});
        if (!ticket) {
            calls.refuse(*this, call->id,
                         "busy: " + link_port_->name() + " has " +
                             std::to_string(CallTable::max_calls_per_port) + " calls outstanding, the limit");
            return true;
        }
        Message message = request;
        message.call = std::move(ticket);
        link_->deliver(message);
        return true;
    }
    const auto it = ports_.find(call->handle);
    if (it == ports_.end() || it->second->closed()) {
        calls.refuse(*this, call->id, "no open port with handle " + std::to_string(call->handle));
        return true;
    }
    const auto& port = it->second;
    if (!check_sources(request, port->name(), "written on the handle of"))
        return false;
    auto chosen = choose_server(*port);
    if (const auto* why = std::get_if<std::string>(&chosen)) {
        calls.refuse(*this, call->id, *why);
        return true;
    }
    Connection& connection = *std::get<Connection*>(chosen);
    if (connection.room() == 0) {
        calls.refuse(
            *this, call->id,
            "busy: the connection " + connection.source + " -> " + connection.destination + " is full");
        return true;
    }
    // The answer passes back the receiving monitors of a connection within this daemon, then its
    // sending ones.
    std::vector<std::shared_ptr<MessageFilter>> reply_through;
    if (const auto* inlet = dynamic_cast<const Inlet*>(connection.sink.get()))
        reply_through.push_back(inlet->monitors);
    reply_through.push_back(connection.send_monitors);
    auto ticket = calls.start(self, call->id, deadline, port->name() + " -> " + connection.destination, port,
                              std::move(reply_through));
    if (!ticket) {
        calls.refuse(*this, call->id,
                     "busy: " + port->name() + " has " + std::to_string(CallTable::max_calls_per_port) +
                         " calls outstanding, the limit");
        return true;
    }
    Message message = request;
    message.call = std::move(ticket);
    send_call(connection, message);
    return true;
}

bool Session::on_answer(const InFrame& frame) {
    const auto answer = proto::decode_answer(frame.fields);
    if (!answer) {
        ++daemon_.counters().protocol_errors;
        fail("bad answer frame: " + answer.error().message);
        return false;
    }
    if (answer->outcome == proto::CallOutcome::ok && !proto::read_record(answer->record)) {
        // Passed on as it is to the caller, whose library would fail on it: refused here.
        ++daemon_.counters().protocol_errors;
        fail("bad answer frame: its reply is not a message record");
        return false;
    }
    daemon_.calls().answer(*this, *answer);
    return true;
}

Task<void> Session::wait_for_space() {
    // While held back this session does not read its socket, so a client that dies now would go
    // unnoticed: look for a hang-up every time the wait times out.
    constexpr auto hang_up_check = std::chrono::milliseconds(100);
    if (co_await daemon_.wait_for_space(hang_up_check))
        co_return;
    if (peer_hung_up())
        close("the peer went away while held back by a full reader");
}

void Session::on_auth_failure(const std::string&) {
    ++daemon_.counters().auth_failures;
}

void Session::on_handshake_timeout() {
    ++daemon_.counters().handshake_timeouts;
}

void Session::on_tls_refused(const std::string&) {
    ++daemon_.counters().tls_records_refused;
}

void Session::on_protocol_error() {
    ++daemon_.counters().protocol_errors;
}

void Session::on_closed(const std::string& reason) {
    spdlog::debug("{} closed: {}", description(), reason);
    shm_regions_.clear();
    daemon_.session_closed(*this);
}

Principal Session::principal() const {
    Principal who;
    if (local_user_) {
        who.user = local_user_;
        return who;
    }
    if (const auto& subject = peer_subject(); subject && subject->kind == proto::Subject::Kind::node)
        who.node = subject->name;
    else if (hello_received() && !peer_hello().node.empty())
        who.node = peer_hello().node;
    return who;
}

}  // namespace plexus::daemon
