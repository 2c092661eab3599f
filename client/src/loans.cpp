// Zero-copy messages: loans written in place in a port's shared memory, and views read in place.
#include <cstring>

#include "connection.hpp"
#include "daemon_link.hpp"
#include "large_payload.hpp"
#include "loan_slot.hpp"
#include "plexus/client.hpp"

namespace plexus {

// --- Loan ---

Loan::Loan(Loan&& other) noexcept
    : slot_(std::move(other.slot_)), heap_(std::move(other.heap_)), bytes_(std::exchange(other.bytes_, {})) {
    if (!slot_)
        bytes_ = heap_;  // a moved vector keeps its buffer, but say so plainly
}

Loan& Loan::operator=(Loan&& other) noexcept {
    if (this != &other) {
        slot_ = std::move(other.slot_);
        heap_ = std::move(other.heap_);
        bytes_ = std::exchange(other.bytes_, {});
        if (!slot_)
            bytes_ = heap_;
    }
    return *this;
}

Loan::~Loan() = default;  // an unsent slot is given back by its LoanSlot

// --- MessageView ---

MessageView::~MessageView() = default;  // the lease, if any, releases the slot

const Envelope& MessageView::envelope() const {
    return lease_ ? lease_->envelope : held_->envelope;
}

Value MessageView::value() const {
    return lease_ ? detail::ShmRegions::copy_out(*lease_).data : held_->data;
}

// --- Port ---

Loan Port::loan(std::size_t size) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    Loan loan;
    auto [connection, handle] = current();
    if (connection && !connection->broken()) {
        try {
            if (auto slot = connection->loan(handle, size)) {
                loan.bytes_ = {slot->region->data + slot->offset + slot->head_size, size};
                loan.slot_ = std::move(slot);
                return loan;
            }
        } catch (const Error&) {
            if (!connection->broken())
                throw;
            link_->lost(connection);
        }
    }
    loan.heap_.resize(size);
    loan.bytes_ = loan.heap_;
    return loan;
}

void Port::send_loan(Loan&& loan, bool flush) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    Loan taken = std::move(loan);
    if (taken.slot_) {
        auto [connection, handle] = current();
        if (connection == taken.slot_->connection && handle == taken.slot_->handle) {
            try {
                connection->send_loan(handle, name_, next_seq_++, *taken.slot_);
                return;
            } catch (const Error&) {
                if (!connection->broken())
                    throw;
                link_->lost(connection);
            }
        }
        // The daemon went away since the loan was made: its bytes are still here, sent as any blob.
    }
    write_blob({}, taken.bytes_, flush);
}

std::optional<MessageView> Port::read_view(std::chrono::milliseconds timeout) {
    if (!next_ready(timeout))
        return std::nullopt;
    auto& inbox = *ready_;
    MessageView view;
    if (auto& segment = inbox.segments.front(); segment.lease) {
        view.lease_ = std::move(segment.lease);
        inbox.segments.pop_front();
        inbox.next = 0;
        const proto::ByteView payload = view.lease_->payload;
        const auto head = detail::parse_byte_string_head(payload);
        if (head && head->head_size + head->length == payload.size())
            view.bytes_ = payload.subspan(head->head_size);
        return view;
    }
    view.held_ = read(std::chrono::milliseconds(0));  // the front segment is there: no wait
    if (view.held_ && view.held_->data.is_binary()) {
        const auto& bytes = view.held_->data.get_binary();
        view.bytes_ = {bytes.data(), bytes.size()};
    }
    return view;
}

}  // namespace plexus
