#include "connection.hpp"

#include <unistd.h>

#include <cstdlib>
#include <cstring>

#include "loan_slot.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/rings.hpp"
#include "plexus/proto/shm.hpp"
#include "tcp_handshake.hpp"

namespace plexus::detail {

namespace {
// Data frames larger than this are worth writing through shared memory once a region is there.
constexpr std::size_t shm_threshold = 64 * 1024;
// How long a write waits for a slot of a full region before it takes the socket instead.
constexpr auto shm_room_wait = std::chrono::milliseconds(100);
}  // namespace

Connection::Connection(int fd, std::string description, bool greeted, std::uint64_t peer_max_frame,
                       std::unique_ptr<TlsChannel> tls)
    : path_(std::move(description)),
      socket_(fd, std::move(tls)),  // first of the parts: it closes the descriptor if this constructor throws
      demux_(path_, demand_),
      calls_(demand_),
      shm_(demand_),
      send_(socket_, demand_),
      releases_(std::make_shared<ReleaseBook>(send_)),
      receiver_(socket_, demand_, demux_, calls_, shm_, send_, rings_answer_, releases_) {
    if (greeted && peer_max_frame > 0)
        receiver_.set_peer_max_frame(peer_max_frame);
    if (!greeted && !send_.send_frame(proto::encode_hello({proto::protocol_version, "client", ""})))
        throw Error(ErrorCode::refused, "connection to " + path_ + " lost: " + send_.failure().value_or(""));
    // Last: once it runs, the destructor must join it.
    receiving_ = std::thread([this] {
        receiver_.run();
        fail_calls();
    });
}

void Connection::fail_calls() {
    std::string why = "connection to " + path_ + " closed";
    try {
        demux_.throw_if_broken();
    } catch (const Error& e) {
        why = e.what();
    }
    calls_.fail_all(why);
}

void Connection::send_frame(proto::ByteView frame) {
    demux_.throw_if_broken();
    check_sent(send_.send_frame(frame));
}

Connection::~Connection() {
    try {
        flush();
    } catch (...) {
        // Nothing to report to in a destructor; the daemon notices the close.
    }
    send_.stop();
    demand_.stop();
    // Wakes the receiving thread from its blocking read (it reads an end of stream and stops);
    // only then may the parts it feeds go. It runs no callbacks (nothing of a component's code
    // runs on it), so this destructor never runs on it and never waits for itself.
    socket_.shutdown();
    if (receiving_.joinable()) {
        // The completion of an asynchronous call runs on the receiving thread: one that let go of
        // the last Client there would end up here, on the thread to join (LOCK_ORDER.md).
        if (receiving_.get_id() == std::this_thread::get_id())
            receiving_.detach();
        else
            receiving_.join();
    }
    fail_calls();         // what is left waiting hears that the connection is gone
    releases_->detach();  // leases still held by views must not reach the SendBuffer that goes now
}

std::shared_ptr<Connection> Connection::to_daemon(const std::string& socket_path) {
    auto connection = std::make_shared<Connection>(FrameSocket::connect_unix(socket_path), socket_path);
    // A wrong program on the socket is reported now rather than at the first real request.
    proto::Reply reply = connection->request(proto::NodeRequest{}.encode(), std::chrono::milliseconds(5000));
    if (reply.code != proto::ReplyCode::ok || !proto::NodeReply::decode(reply.body))
        throw Error(ErrorCode::refused, "the program at " + socket_path + " is not plexusd");
    // PLEXUS_SHM=0 keeps every payload in the socket (for comparisons, or to rule shm out).
    const char* shm = std::getenv("PLEXUS_SHM");
    if (!shm || std::string_view(shm) != "0")
        connection->enable_shm();
    // PLEXUS_RINGS=0 keeps the frames in the socket (for comparisons, or to rule the rings out).
    const char* rings = std::getenv("PLEXUS_RINGS");
    if (!rings || std::string_view(rings) != "0")
        connection->enable_rings();
    return connection;
}

bool Connection::enable_rings() {
    // Nothing else is sent meanwhile: this runs before the connection is handed to anyone, and the
    // daemon reads nothing more from the socket after the request.
    const auto deadline = Clock::now() + std::chrono::milliseconds(5000);
    demand_.add(deadline);
    if (!send_.send_frame(proto::make_rings_request(0))) {
        demand_.remove();
        check_sent(false);
    }
    auto answer = rings_answer_.wait(deadline);
    demand_.remove();
    demux_.throw_if_broken();
    if (!answer)
        throw Error(ErrorCode::timeout, path_ + " did not answer the rings request in time");
    if (!answer->rings)
        return false;
    check_sent(send_.send_into_rings(std::move(answer->rings)));
    return true;
}

std::shared_ptr<Connection> Connection::to_names(const std::string& address) {
    const int fd = FrameSocket::connect_tcp(address);
    TcpGreeting greeting;
    try {
        greeting = tcp_handshake(fd, address, "names", std::chrono::milliseconds(10000));
    } catch (...) {
        ::close(fd);
        throw;
    }
    return std::make_shared<Connection>(fd, address, true, greeting.peer_max_frame, std::move(greeting.tls));
}

bool Connection::enable_shm() {
    const proto::Reply reply = request(proto::ShmRequest{}.encode(), std::chrono::milliseconds(5000));
    const bool on = reply.code == proto::ReplyCode::ok;
    shm_.enable(on);
    return on;
}

void Connection::check_sent(bool sent) {
    if (sent)
        return;
    demux_.fail(send_.failure().value_or("sending failed"));
    fail_calls();
    demux_.throw_if_broken();
}

proto::Reply Connection::request(nlohmann::json body, std::chrono::milliseconds timeout) {
    // The daemon would take a deeper body for a broken peer and cut the session off.
    if (proto::nesting_depth(body, proto::max_body_depth) > proto::max_body_depth) {
        throw Error(ErrorCode::usage, "the request nests arrays and maps deeper than " +
                                          std::to_string(proto::max_cbor_depth) + " levels");
    }
    const std::uint64_t id = demux_.expect_reply();
    if (!send_.send_frame(proto::encode_request({id, std::move(body)}))) {
        demux_.cancel_reply(id);  // no reply will come for a request that was not sent
        check_sent(false);
    }
    auto reply = demux_.wait_reply(id, Clock::now() + timeout);
    if (!reply)
        throw Error(ErrorCode::timeout, path_ + " did not answer in time");
    return std::move(*reply);
}

void Connection::write(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                       proto::ByteView payload, proto::ByteView tail, bool flush) {
    if (!tail.empty() && payload.size() + tail.size() < SendBuffer::gather_threshold) {
        // Not the large payload a tail is for: one piece, as any other.
        proto::Bytes whole(payload.begin(), payload.end());
        whole.insert(whole.end(), tail.begin(), tail.end());
        return write(handle, source, seq, whole, {}, flush);
    }
    demux_.throw_if_broken();
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    const auto time_ns =
        static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now).count());
    const std::size_t payload_size = payload.size() + tail.size();
    if (payload_size >= shm_threshold && write_through_shm(handle, source, seq, time_ns, payload, tail))
        return;
    check_sent(send_.write(handle, source, seq, time_ns, payload, tail, flush));
    demux_.throw_if_broken();
}

bool Connection::read_all(std::uint64_t handle, std::chrono::milliseconds timeout,
                          std::deque<InboxSegment>& into) {
    if (timeout.count() > 0) {
        // Reading here, when the receiving thread is not, wakes one thread per message (this one)
        // instead of two (the receiving thread, which would then wake this one).
        bool taken = false;
        const auto deadline = Clock::now() + timeout;
        if (receiver_.read_for([&] { return taken = demux_.take_now(handle, into); }, deadline))
            return taken || demux_.take_now(handle, into);
    }
    return demux_.take_all(handle, timeout, into);
}

void Connection::flush() {
    check_sent(send_.flush());
}

void Connection::forget(std::uint64_t handle) {
    demux_.close(handle);
    shm_.forget(handle);
}

bool Connection::write_through_shm(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                                   std::uint64_t time_ns, proto::ByteView payload, proto::ByteView tail) {
    const std::size_t length = payload.size() + tail.size();
    if (length > proto::default_max_frame)
        return false;  // the daemon takes no payload larger than a frame, however it comes
    const auto region = writer_region(handle, length);
    if (!region || length > region->size)
        return false;  // no region, or one sized for smaller payloads than this one
    const auto offset = shm_.allocate(*region, length, shm_room_wait);
    if (!offset)
        return false;
    std::memcpy(region->data + *offset, payload.data(), payload.size());
    if (!tail.empty())
        std::memcpy(region->data + *offset + payload.size(), tail.data(), tail.size());
    proto::Bytes place;
    proto::append_shm_place(place, {region->id, *offset, length}, source, seq, time_ns);
    check_sent(send_.write_shm(handle, place));
    demux_.throw_if_broken();
    return true;
}

LoanSlot::~LoanSlot() {
    if (!sent)
        connection->give_back(*region, offset);
}

std::shared_ptr<LoanSlot> Connection::loan(std::uint64_t handle, std::size_t size) {
    demux_.throw_if_broken();
    proto::Bytes head;
    proto::append_byte_string_head(head, size);
    const std::size_t length = head.size() + size;
    if (length > proto::default_max_frame)
        return nullptr;  // the daemon takes no payload larger than a frame, however it comes
    const auto region = writer_region(handle, length);
    if (!region || length > region->size)
        return nullptr;
    const auto offset = shm_.allocate(*region, length, shm_room_wait);
    if (!offset)
        return nullptr;
    std::memcpy(region->data + *offset, head.data(), head.size());
    return std::make_shared<LoanSlot>(shared_from_this(), handle, region, *offset, length, head.size());
}

void Connection::send_loan(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                           LoanSlot& slot) {
    demux_.throw_if_broken();
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    const auto time_ns =
        static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now).count());
    proto::Bytes place;
    proto::append_shm_place(place, {slot.region->id, slot.offset, slot.length}, source, seq, time_ns);
    slot.sent = true;  // from here the daemon frees it (shm_free), whatever happens to the send
    check_sent(send_.write_shm(handle, place));
    demux_.throw_if_broken();
}

std::shared_ptr<WriterRegion> Connection::writer_region(std::uint64_t handle, std::size_t payload_size) {
    if (auto known = shm_.writer_region(handle))
        return *known;
    // The first large write on this port asks for its region. The region's frame (and its
    // descriptor) comes before the reply, and the receiving thread handles frames in order: it is
    // in shm_ once the reply is here.
    const proto::Reply reply =
        request(proto::ShmRequest{handle, payload_size}.encode(), std::chrono::milliseconds(5000));
    std::optional<std::uint64_t> id;
    if (reply.code == proto::ReplyCode::ok) {  // else shared memory is used up or off: the socket
        if (const auto answer = proto::ShmReply::decode(reply.body))
            id = answer->region.value_or(0);  // not an answer this library understands: the socket
    }
    return shm_.assign(handle, id);
}

}  // namespace plexus::detail
