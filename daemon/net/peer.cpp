#include "peer.hpp"

#include <spdlog/spdlog.h>

#include "call_table.hpp"
#include "keepalive.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon {

struct Peer::Pending {
    explicit Pending(const asio::any_io_executor& executor) : done(executor) {}
    std::optional<proto::Reply> reply;
    Signal done;
};

Peer::Peer(Socket socket, std::size_t max_frame, std::function<void()> on_space, std::string description)
    : FramedConnection(std::move(socket), max_frame, std::move(on_space)) {
    set_description(std::move(description));
}

Task<proto::Result<std::shared_ptr<Peer>>> Peer::connect(asio::any_io_executor executor,
                                                         proto::Endpoint endpoint, proto::Hello mine,
                                                         std::size_t max_frame, Duration timeout,
                                                         std::function<void()> on_space,
                                                         std::optional<proto::Secret> secret) {
    using namespace asio::experimental::awaitable_operators;
    using Outcome = proto::Result<std::shared_ptr<Peer>>;
    const std::string where = endpoint.text();
    asio::ip::tcp::resolver resolver(executor);
    asio::steady_timer deadline(executor, timeout);
    auto resolved =
        co_await (resolver.async_resolve(endpoint.host, std::to_string(endpoint.port), use_nothrow) ||
                  deadline.async_wait(use_nothrow));
    if (resolved.index() == 1)
        co_return Outcome(proto::Error{"timed out resolving " + where});
    auto [resolve_error, results] = std::get<0>(resolved);
    if (resolve_error)
        co_return Outcome(proto::Error{"cannot resolve " + where + ": " + resolve_error.message()});

    asio::ip::tcp::socket tcp_socket(executor);
    auto connected =
        co_await (asio::async_connect(tcp_socket, results, use_nothrow) || deadline.async_wait(use_nothrow));
    if (connected.index() == 1)
        co_return Outcome(proto::Error{"timed out connecting to " + where});
    auto [connect_error, unused] = std::get<0>(connected);
    if (connect_error)
        co_return Outcome(proto::Error{"cannot connect to " + where + ": " + connect_error.message()});
    tcp_socket.set_option(asio::ip::tcp::no_delay(true));
    keep_alive(tcp_socket.native_handle());

    auto peer = std::make_shared<Peer>(Socket(std::move(tcp_socket)), max_frame, std::move(on_space), where);
    peer->require_secret(std::move(secret), proto::Party::connecting);
    peer->start(mine);
    const auto left = deadline.expiry() - std::chrono::steady_clock::now();
    if (!co_await peer->wait_for_hello(left)) {
        std::string reason = peer->closed_reason_.empty() ? "no hello in time" : peer->closed_reason_;
        peer->close("handshake failed");
        co_return Outcome(proto::Error{"handshake with " + where + " failed: " + reason});
    }
    co_return Outcome(std::move(peer));
}

Task<proto::Result<proto::Reply>> Peer::request(nlohmann::json body, Duration timeout) {
    using Outcome = proto::Result<proto::Reply>;
    auto self = shared_from_this();
    if (closed())
        co_return Outcome(proto::Error{description() + " is closed: " + closed_reason_});
    const std::uint64_t id = next_id_++;
    auto pending = std::make_shared<Pending>(executor());
    pending_.emplace(id, pending);
    send(proto::encode_request({id, std::move(body)}));
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!pending->reply && !closed()) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline)
            break;
        co_await pending->done.wait_for(deadline - now);
    }
    pending_.erase(id);
    if (pending->reply)
        co_return Outcome(std::move(*pending->reply));
    if (closed())
        co_return Outcome(proto::Error{description() + " closed: " + closed_reason_});
    co_return Outcome(proto::Error{description() + " did not answer in time"});
}

proto::Status Peer::on_hello(const proto::Hello&) {
    return proto::Ok{};
}

Task<bool> Peer::on_frame(InFrame frame) {
    if (frame.type == proto::FrameType::answer) {
        // The answer to a call this daemon sent on the link (only a link that carried a call has
        // a table; any other answer is counted there as unknown, or refused here).
        const auto answer = proto::decode_answer(frame.fields);
        if (!answer || (answer->outcome == proto::CallOutcome::ok && !proto::read_record(answer->record))) {
            fail("bad answer frame: " +
                 (answer ? std::string("its reply is not a message record") : answer.error().message));
            co_return false;
        }
        if (auto* calls = call_table()) {
            calls->answer(*this, *answer);
            co_return true;
        }
        fail("an answer on a link that carried no call");
        co_return false;
    }
    if (frame.type != proto::FrameType::reply) {
        fail("unexpected " + proto::frame_type_name(static_cast<std::uint8_t>(frame.type)) + " frame");
        co_return false;
    }
    auto reply = proto::decode_reply(frame.fields);
    if (!reply) {
        fail("bad reply: " + reply.error().message);
        co_return false;
    }
    auto it = pending_.find(reply->id);
    if (it != pending_.end()) {
        it->second->reply = std::move(*reply);
        it->second->done.notify();
    }
    co_return true;
}

void Peer::on_closed(const std::string& reason) {
    closed_reason_ = reason;
    for (auto& [id, pending] : pending_)
        pending->done.notify();
    if (closed_handler) {
        auto handler = std::move(closed_handler);
        closed_handler = nullptr;
        handler(reason);
    }
}

}  // namespace plexus::daemon
