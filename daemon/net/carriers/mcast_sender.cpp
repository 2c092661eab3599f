// The multicast sending end of a source port (mcast_sender.hpp).
#include "mcast_sender.hpp"

#include "../../core/batch.hpp"

namespace plexus::daemon::carriers {

McastSender::~McastSender() {
    if (stage_)
        stage_->close();  // the monitors go on their worker; nothing more comes back
}

proto::Result<bool> McastSender::share_send_clauses(const std::string& clauses) {
    if (!clauses_) {
        clauses_ = clauses;
        return true;
    }
    if (*clauses_ != clauses) {
        return proto::Error{"mcast connections of " + source_ +
                            " share one stream and so its send-side monitors: "
                            "they are '" +
                            *clauses_ + "', not '" + clauses + "'"};
    }
    return false;  // the new connection's own monitors go: the shared ones serve it
}

void McastSender::deliver(const Message& message) {
    // Every mcast connection of the port hands over the same unit, one after the other: send it
    // for the first only.
    if (last_.storage == message.storage && last_.record.data() == message.record.data() &&
        last_.record.size() == message.record.size() && message.storage) {
        return;
    }
    last_ = message;
    if (stage_)
        stage_->submit(message);  // what the monitors pass comes back through filtered()
    else
        send(message);
}

void McastSender::filtered(std::vector<Filtered>& results) {
    for (const auto& result : results) {
        if (result.verdict == FilterVerdict::pass)
            send(result.message);
        else
            counters_.dropped_by_monitor += result.message.count();
    }
}

void McastSender::send(const Message& message) {
    for_each_record(message, [this](const Message& single) {
        socket_.send_counted(group_, 0, stream_.next_message, single.record, counters_, "mcast " + source_,
                             marks_ ? &*marks_ : nullptr, socket_.sealing() ? &stream_.seal : nullptr);
    });
}

void McastSender::mark(int dscp) {
    if (dscp_ && *dscp_ >= dscp)
        return;
    dscp_ = dscp;
    marks_ = socket_.marks_for(dscp);
}

}  // namespace plexus::daemon::carriers
