#pragma once
// Threading: one io_context thread.

#include <memory>

#include <nlohmann/json.hpp>

#include "../../core/connection.hpp"
#include "../../core/reader_queue.hpp"
#include "../peer.hpp"
#include "carrier.hpp"

namespace plexus::daemon::carriers {

/// The sending end of a tcp connection: messages wait in a queue and leave on the peer's socket as
/// data frames. Into a strict port the queue is strict: a full one holds the writer back (TCP
/// back-pressure, end to end). Into a latest port it is a latest queue that drops its oldest
/// message (counted) rather than hold anyone back, so that on a slow network the reader gets the
/// newest data, not a backlog.
class TcpLink : public MessageSink {
public:
    TcpLink(std::shared_ptr<Peer> peer, std::size_t capacity, std::size_t max_bytes,
            QueuePolicy policy = QueuePolicy::strict)
        : peer_(std::move(peer)), queue_(std::make_shared<ReaderQueue>(policy, capacity, max_bytes)) {
        peer_->outbox().add_source({0, queue_.get(), nullptr, queue_});
    }
    bool full() const override { return queue_->full(); }
    std::size_t room() const override { return queue_->room(); }
    void deliver(const Message& message) override {
        const bool was_empty = queue_->empty();
        queue_->push(message);
        if (was_empty)
            peer_->wake();
    }
    void close_after_flush() override { peer_->close_when_drained(); }
    void report_stats(nlohmann::json& entry) const override {
        entry["queued"] = queued();
        entry["dropped_latest"] = dropped();  // a link into a latest port keeps the newest
    }
    /// Messages still queued (lost if the link died).
    std::size_t queued() const { return queue_->depth(); }
    /// Messages a latest link dropped to keep its queue short.
    std::uint64_t dropped() const { return queue_->dropped(); }
    /// The queue itself, for whoever must count what is left in it after the link is gone.
    std::shared_ptr<const ReaderQueue> queue() const { return queue_; }
    const std::shared_ptr<Peer>& peer() const { return peer_; }

private:
    std::shared_ptr<Peer> peer_;
    std::shared_ptr<ReaderQueue> queue_;
};

/// tcp: reliable and ordered, the carrier between daemons when a connect names none. Messages
/// leave through a TcpLink on the link that attached the connection, and the link session at the
/// receiving daemon feeds the inlet with them (the default receiving end).
class TcpCarrier final : public Carrier {
public:
    std::string_view name() const override { return "tcp"; }
    proto::Result<SendingEnd> make_sending_end(const SendingContext& context) const override;
};

}  // namespace plexus::daemon::carriers
