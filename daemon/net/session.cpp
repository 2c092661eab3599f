#include "session.hpp"

#include <spdlog/spdlog.h>

#include "../core/router.hpp"
#include "../daemon.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon {

Session::Session(Socket socket, Daemon& daemon, std::uint64_t id)
    : FramedConnection(std::move(socket), daemon.config().max_frame, [&daemon] { daemon.notify_space(); }),
      daemon_(daemon),
      id_(id) {}

proto::Status Session::on_hello(const proto::Hello& hello) {
    if (hello.role != "client" && hello.role != "daemon" && hello.role != "link") {
        return proto::Error{"unknown role '" + hello.role + "' (expected client, daemon or link)"};
    }
    role_ = hello.role;
    return proto::Ok{};
}

void Session::become_link(std::shared_ptr<Inlet> link) {
    link_port_ = link->port();
    link_ = std::move(link);
}

Task<bool> Session::on_frame(InFrame frame) {
    switch (frame.type) {
        case proto::FrameType::data:
            co_return co_await on_data(std::move(frame));
        case proto::FrameType::request: {
            auto request = proto::decode_request(frame.fields);
            if (!request) {
                ++daemon_.counters().protocol_errors;
                fail("bad request: " + request.error().message);
                co_return false;
            }
            auto self = std::static_pointer_cast<Session>(shared_from_this());
            // Requests may wait on other daemons: serve each on its own coroutine so data keeps flowing.
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
        reply = co_await daemon_.handle(self, std::move(request));
    } catch (const std::exception& e) {
        // A malformed field (wrong JSON type) must not take the daemon down: refuse the request.
        reply =
            proto::make_refusal(id, proto::ReplyCode::usage, std::string("malformed request: ") + e.what());
    }
    reply.id = id;
    send(proto::encode_reply(reply));
}

Session::DataOutcome Session::try_deliver(const InFrame& frame) {
    auto data = proto::decode_data(frame.fields);
    if (!data) {
        ++daemon_.counters().protocol_errors;
        fail("bad data frame: " + data.error().message);
        return DataOutcome::stop;
    }
    auto record = proto::decode_record(data->record);
    if (!record) {
        ++daemon_.counters().protocol_errors;
        fail("bad message record: " + record.error().message);
        return DataOutcome::stop;
    }
    if (link_port_) {
        // The receiving end of a connection from another daemon: hold back while the reader is full,
        // so that TCP carries the back-pressure to the sending daemon.
        if (record->source != link_->source()) {
            ++daemon_.counters().protocol_errors;
            fail("message from port '" + std::string(record->source) + "' on the link attached for " +
                 link_->source());
            return DataOutcome::stop;
        }
        if (link_port_->closed() || closed())
            return DataOutcome::stop;
        if (link_port_->full())
            return DataOutcome::blocked;
        link_->deliver(Message{frame.storage, data->record, record->seq});
        return DataOutcome::delivered;
    }
    auto it = ports.find(data->handle);
    if (it == ports.end() || it->second->closed()) {
        // The client may write while its close is in flight; count it rather than cut it off.
        ++daemon_.counters().dropped_unknown_port;
        return DataOutcome::delivered;
    }
    Port& port = *it->second;
    if (record->source != port.name()) {
        ++daemon_.counters().protocol_errors;
        fail("message from port '" + std::string(record->source) + "' written on the handle of " +
             port.name());
        return DataOutcome::stop;
    }
    if (Router::blocked(port))
        return DataOutcome::blocked;
    Router::route(port, Message{frame.storage, data->record, record->seq});
    return DataOutcome::delivered;
}

FramedConnection::FrameAction Session::on_frame_now(InFrame& frame) {
    if (frame.type != proto::FrameType::data)
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

Task<bool> Session::on_data(InFrame frame) {
    for (;;) {
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

Task<void> Session::wait_for_space() {
    // While held back this session does not read its socket, so a client that dies now would go
    // unnoticed: look for a hang-up every time the wait times out.
    constexpr auto hang_up_check = std::chrono::milliseconds(100);
    if (co_await daemon_.space().wait_for(hang_up_check))
        co_return;
    if (peer_hung_up())
        close("the peer went away while held back by a full reader");
}

void Session::on_closed(const std::string& reason) {
    spdlog::debug("{} closed: {}", description(), reason);
    daemon_.session_closed(*this);
}

}  // namespace plexus::daemon
