// What every carrier does unless it says otherwise (carrier.hpp).
#include "carrier.hpp"

namespace plexus::daemon::carriers {

Task<proto::Result<proto::AttachRequest>> Carrier::prepare_attach(CarrierHost&,
                                                                  proto::AttachRequest request) const {
    co_return request;
}

Task<proto::Result<proto::AttachReply>> Carrier::attach_receiving_end(ReceivingContext,
                                                                      proto::AttachReply answer) const {
    co_return answer;
}

std::shared_ptr<MessageFilter> own_send_monitors(const SendingContext& context, const MessageSink& sink) {
    if (!context.make_send_stage)
        return nullptr;
    const bool never_holds_back = sink.room() >= never_full_room;
    return context.make_send_stage(context.connection, never_holds_back);
}

}  // namespace plexus::daemon::carriers
