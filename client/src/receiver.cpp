#include "receiver.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cstring>

#include "blob_pool.hpp"
#include "large_payload.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"

namespace plexus::detail {

namespace {
/// Bytes the receive buffer grows by; it takes more when less than a quarter is free.
constexpr std::size_t read_chunk = 256 * 1024;
}  // namespace

Receiver::Receiver(FrameSocket& socket, ReadDemand& demand, Demux& demux, CallBook& calls, ShmRegions& shm,
                   SendBuffer& send, RingsAnswerSlot& rings_answer, std::shared_ptr<ReleaseBook> releases)
    : socket_(socket),
      demand_(demand),
      demux_(demux),
      calls_(calls),
      shm_(shm),
      send_(send),
      rings_answer_(rings_answer),
      releases_(std::move(releases)) {
    in_.resize(read_chunk);
}

Receiver::~Receiver() {
    for (const int fd : received_fds_)
        ::close(fd);
}

thread_local const Receiver* Receiver::reading_here = nullptr;

void Receiver::run() {
    while (const auto deadline = demand_.wait()) {
        std::unique_lock turn(turn_);
        reading_here = this;
        receive(*deadline);
        reading_here = nullptr;
        turn.unlock();
        if (demux_.broken())
            return;
        // Releases for the data_shm frames just taken go back at once when no other thread is
        // sending (one that is appends them to its frames).
        send_.send_releases_if_idle();
    }
}

void Receiver::fail(const std::string& why) {
    demux_.fail(why);
}

void Receiver::receive(Clock::time_point deadline) {
    // One blocking recvmsg with a receive timeout, instead of poll + recvmsg: on the latency path
    // every system call counts. The timeout is the latest deadline of those waiting, so that the
    // socket is not read on for a wait that ended (that would read ahead of the ports). It is only
    // reset when it would overshoot the deadline by more than a millisecond, or wake up far too
    // early, so a loop of read(1s) sets it once. The end comes with the socket's shutdown
    // (Connection's destructor) or the peer's close.
    int flags = 0;
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now());
    if (left.count() <= 0) {
        flags = MSG_DONTWAIT;
    } else if (receive_timeout_.count() == 0 || receive_timeout_ > left + std::chrono::milliseconds(1) ||
               receive_timeout_ < left / 2) {
        // 0 means "no timeout" to the kernel: a first deadline under 2 us must still set one.
        socket_.set_receive_timeout(left);
        receive_timeout_ = left;
    }
    if (large_) {
        receive_large_payload(flags);
        return;
    }
    if (in_begin_ == in_end_)
        in_begin_ = in_end_ = 0;
    if (in_.size() - in_end_ < read_chunk / 4) {
        // Slide the unread part to the front, growing only when one frame needs more room.
        std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
        in_end_ -= in_begin_;
        in_begin_ = 0;
        if (in_.size() - in_end_ < read_chunk / 4)
            in_.resize(in_.size() * 2);
    }
    const std::size_t n = receive_into(in_.data() + in_end_, in_.size() - in_end_, flags);
    if (n == 0)
        return;
    in_end_ += n;
    static const proto::FrameDecoder decoder(proto::default_max_frame);
    received_.clear();
    for (;;) {
        auto decoded = decoder.decode({in_.data() + in_begin_, in_end_ - in_begin_});
        if (decoded.status == proto::DecodeStatus::bad) {
            deliver_received();
            fail("bad frame from the daemon: " + decoded.error);
            return;
        }
        if (decoded.status == proto::DecodeStatus::need_more) {
            deliver_received();  // before the tail moves: received_ holds offsets into in_
            if (start_large_payload(decoded.needed))
                return;
            if (decoded.needed > in_.size() - in_begin_) {
                std::memmove(in_.data(), in_.data() + in_begin_, in_end_ - in_begin_);
                in_end_ -= in_begin_;
                in_begin_ = 0;
                in_.resize(std::max(in_.size(), decoded.needed));
            }
            return;
        }
        if (decoded.type == proto::FrameType::data) {
            auto data = proto::decode_data(decoded.fields);
            if (!data) {
                deliver_received();
                return fail("bad data frame: " + data.error().message);
            }
            received_.push_back({data->handle, static_cast<std::size_t>(data->record.data() - in_.data()),
                                 data->record.size()});
        } else if (decoded.type == proto::FrameType::data_batch) {
            auto batch = proto::decode_batch(decoded.fields);
            if (!batch) {
                deliver_received();
                return fail(batch.error().message);
            }
            const std::size_t before = received_.size();
            proto::BatchRecords records(batch->records, batch->count);
            while (const auto record = records.next()) {
                received_.push_back(
                    {batch->handle, static_cast<std::size_t>(record->data() - in_.data()), record->size()});
            }
            if (!records.error().empty()) {
                received_.resize(before);  // none of a broken batch is delivered
                deliver_received();
                return fail(records.error());
            }
        } else if (decoded.type == proto::FrameType::data_shm) {
            deliver_received();  // the records before it go first
            receive_shm_data(decoded.fields);
            if (demux_.broken())
                return;
        } else {
            dispatch(decoded.type, decoded.fields);
            if (demux_.broken())
                return;
        }
        in_begin_ += decoded.used;
        if (just_moved_to_rings_) {
            // The daemon sends nothing on the socket after its rings answer but descriptors, each
            // with one byte: those bytes are not frames.
            just_moved_to_rings_ = false;
            in_begin_ = in_end_ = 0;
            return;
        }
    }
}

std::size_t Receiver::receive_into(std::uint8_t* at, std::size_t room, int flags) {
    const SocketReceived result = socket_.receive(at, room, received_fds_, flags);
    if (result.failure)
        fail(*result.failure);
    return result.bytes;
}

bool Receiver::start_large_payload(std::size_t frame_size) {
    const proto::ByteView start(in_.data() + in_begin_, in_end_ - in_begin_);
    auto frame = parse_large_payload_frame(start, frame_size);
    if (!frame)
        return false;
    // Sized (and so zeroed) once: the kernel's copy then writes into pages already there. A
    // recycled buffer (blob_pool.hpp) has its pages already.
    std::vector<std::uint8_t> bytes = take_blob_buffer(frame->payload_size);
    bytes.resize(frame->payload_size);
    large_.emplace(LargePayload{frame->handle,
                                Received{std::move(frame->envelope), Value::binary(std::move(bytes))},
                                nullptr, frame->payload_size});
    large_->at = large_->message.data.get_binary().data();
    // The part of the payload already here (everything in in_ belongs to this frame: it is not whole).
    const std::size_t here = start.size() - frame->payload_offset;
    std::memcpy(large_->at, start.data() + frame->payload_offset, here);
    large_->at += here;
    large_->left -= here;
    in_begin_ = in_end_ = 0;
    return true;
}

void Receiver::receive_large_payload(int flags) {
    if (large_->left > 0) {
        const std::size_t n = receive_into(large_->at, large_->left, flags);
        large_->at += n;
        large_->left -= n;
        if (large_->left > 0)
            return;
    }
    demux_.deliver(large_->handle, InboxSegment{nullptr, {}, std::move(large_->message), nullptr});
    large_.reset();
}

void Receiver::deliver_received() {
    if (received_.empty())
        return;
    const std::size_t first = received_.front().offset;
    const std::size_t last = received_.back().offset + received_.back().size;
    auto block = std::make_shared<const proto::Bytes>(in_.begin() + static_cast<std::ptrdiff_t>(first),
                                                      in_.begin() + static_cast<std::ptrdiff_t>(last));
    deliveries_.clear();
    for (const auto& data : received_)
        deliveries_.push_back(
            {data.handle, proto::ByteView(block->data() + (data.offset - first), data.size)});
    demux_.deliver(block, deliveries_);
    received_.clear();
}

void Receiver::dispatch(proto::FrameType type, proto::ByteView fields) {
    switch (type) {
        case proto::FrameType::hello: {
            // Its max_frame bounds what this client may send (Port::send refuses larger messages).
            if (auto hello = proto::decode_hello(fields); hello && hello->max_frame > 0)
                peer_max_frame_.store(hello->max_frame, std::memory_order_relaxed);
            return;
        }
        case proto::FrameType::reply: {
            auto reply = proto::decode_reply(fields);
            if (!reply)
                return fail("bad reply: " + reply.error().message);
            return demux_.deliver_reply(std::move(*reply));
        }
        case proto::FrameType::error: {
            const auto reason = proto::decode_error(fields);
            return fail("the daemon reported: " +
                        (reason ? *reason : std::string(proto::as_string_view(fields))));
        }
        case proto::FrameType::rings:
            return take_rings(fields);
        case proto::FrameType::shm_region:
            // With rings, its descriptor came on the socket ahead of it: perhaps not read yet.
            if (received_fds_.empty() && socket_.receives_from_rings())
                socket_.await_descriptor(received_fds_, 5000);
            [[fallthrough]];
        case proto::FrameType::shm_free:
        case proto::FrameType::shm_region_gone:
            if (auto bad = shm_.on_frame(type, fields, received_fds_))
                fail(*bad);
            return;
        case proto::FrameType::call: {
            // A call to one of this client's served ports: kept for its Service, by handle.
            const auto call = proto::decode_call(fields);
            if (!call)
                return fail("bad call frame: " + call.error().message);
            return calls_.deliver(call->handle,
                                  IncomingCall{call->id, call->timeout_ms,
                                               proto::Bytes(call->record.begin(), call->record.end())});
        }
        case proto::FrameType::answer: {
            // The answer to a call this client made; its completion runs here, with no lock held.
            const auto answer = proto::decode_answer(fields);
            if (!answer)
                return fail("bad answer frame: " + answer.error().message);
            calls_.complete(answer->id, CallAnswer{answer->outcome,
                                                   proto::Bytes(answer->record.begin(), answer->record.end()),
                                                   std::string(answer->reason)});
            return;
        }
        default:
            return fail("unexpected frame type " + proto::frame_type_name(static_cast<std::uint8_t>(type)));
    }
}

void Receiver::take_rings(proto::ByteView fields) {
    const auto answer = proto::decode_rings_answer(fields);
    if (!answer)
        return fail("bad rings frame: " + answer.error().message);
    if (answer->ring_bytes == 0) {
        rings_answer_.put({nullptr, answer->reason});
        return;
    }
    if (socket_.receives_from_rings())
        return fail("the daemon sent a second rings answer");
    std::vector<int> fds;
    while (!received_fds_.empty() && fds.size() < proto::ring_descriptors) {
        fds.push_back(received_fds_.front());
        received_fds_.pop_front();
    }
    std::string why;
    auto rings = ClientRings::map(std::move(fds), answer->ring_bytes, why);
    if (!rings) {
        // The daemon writes into the rings from now on: without them this connection is over.
        rings_answer_.put({nullptr, why});
        return fail("cannot use the daemon's rings: " + why);
    }
    socket_.receive_from_rings(rings);
    just_moved_to_rings_ = true;
    rings_answer_.put({std::move(rings), {}});
}

void Receiver::receive_shm_data(proto::ByteView fields) {
    const auto data = proto::decode_shm_data(fields);
    if (!data)
        return fail("bad data_shm frame: " + data.error().message);
    // A ticket before anything else: the daemon holds the slot until it is released, whatever
    // becomes of the message here (the lease releases it when it goes, also right away).
    const std::uint64_t ticket = releases_->issue();
    if (auto bad = shm_.check(*data)) {
        releases_->release(ticket);
        return fail(*bad);
    }
    if (!demux_.accepts(data->handle)) {
        releases_->release(ticket);  // a closed port: nothing to hold it for
        return;
    }
    demux_.deliver(data->handle, shm_.lease(*data, releases_, ticket));
}

}  // namespace plexus::detail
