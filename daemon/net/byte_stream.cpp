#include "byte_stream.hpp"

#include <boost/asio/ssl.hpp>

#include "tls_context.hpp"

namespace plexus::daemon {

namespace {
// Small frames are gathered into one TLS record's worth before they are encrypted: a record per
// frame would cost a system call and 22 bytes each. Larger pieces go as they are.
constexpr std::size_t record_bytes = 16 * 1024;
}  // namespace

struct ByteStream::Tls {
    Tls(Socket& socket, TlsContext& context) : stream(socket, context.asio_context()) {}
    asio::ssl::stream<Socket&> stream;
    proto::Bytes gathered;  ///< small pieces waiting to be written as one
};

ByteStream::ByteStream(Socket socket) : socket_(std::move(socket)) {}

ByteStream::~ByteStream() = default;

bool ByteStream::is_tls_error(const boost::system::error_code& error) {
    return error.category() == asio::error::get_ssl_category();
}

Task<proto::Status> ByteStream::start_tls(TlsContext& context, bool accepting, proto::ByteView first) {
    tls_ = std::make_unique<Tls>(socket_, context);
    auto [error, used] = co_await tls_->stream.async_handshake(
        accepting ? asio::ssl::stream_base::server : asio::ssl::stream_base::client, asio::buffer(first),
        use_nothrow);
    if (error) {
        tls_.reset();
        // Asio took OpenSSL's reason off its queue into the error: its message is the reason.
        co_return proto::Error{"TLS handshake failed: " + error.message()};
    }
    co_return proto::Ok{};
}

// The plain paths return the socket's own operation: no coroutine frame of ours on the data path.
Task<std::tuple<boost::system::error_code, std::size_t>> ByteStream::read_some(asio::mutable_buffer buffer) {
    if (tls_)
        return read_tls(buffer);
    if (!given_back_.empty())
        return read_given_back(buffer);
    return socket_.async_read_some(buffer, use_nothrow);
}

Task<std::tuple<boost::system::error_code, std::size_t>> ByteStream::read_given_back(
    asio::mutable_buffer buffer) {
    const std::size_t n = asio::buffer_copy(buffer, asio::buffer(given_back_));
    given_back_.erase(given_back_.begin(), given_back_.begin() + static_cast<std::ptrdiff_t>(n));
    co_return std::tuple{boost::system::error_code{}, n};
}

Task<std::tuple<boost::system::error_code, std::size_t>> ByteStream::write(
    const std::vector<asio::const_buffer>& buffers) {
    return tls_ ? write_tls(buffers) : asio::async_write(socket_, buffers, use_nothrow);
}

Task<std::tuple<boost::system::error_code, std::size_t>> ByteStream::read_tls(asio::mutable_buffer buffer) {
    auto [error, n] = co_await tls_->stream.async_read_some(buffer, use_nothrow);
    if (error == asio::ssl::error::stream_truncated)
        error = asio::error::eof;
    co_return std::tuple{error, n};
}

Task<std::tuple<boost::system::error_code, std::size_t>> ByteStream::write_tls(
    const std::vector<asio::const_buffer>& buffers) {
    std::size_t written = 0;
    auto& gathered = tls_->gathered;
    auto flush = [&]() -> Task<boost::system::error_code> {
        if (gathered.empty())
            co_return boost::system::error_code{};
        auto [error, n] = co_await asio::async_write(tls_->stream, asio::buffer(gathered), use_nothrow);
        written += n;
        gathered.clear();
        co_return error;
    };
    // `buffers` is the writer's batch, which nothing else touches while the writer waits here (it
    // is the writer's own local, and the writer is suspended in this call).
    for (const auto& piece : buffers) {
        if (piece.size() < record_bytes) {
            const auto* bytes = static_cast<const std::uint8_t*>(piece.data());
            gathered.insert(gathered.end(), bytes, bytes + piece.size());
            if (gathered.size() < record_bytes)
                continue;
            if (auto error = co_await flush())
                co_return std::tuple{error, written};
            continue;
        }
        if (auto error = co_await flush())
            co_return std::tuple{error, written};
        auto [error, n] = co_await asio::async_write(tls_->stream, piece, use_nothrow);
        written += n;
        if (error)
            co_return std::tuple{error, written};
    }
    co_return std::tuple{co_await flush(), written};
}

}  // namespace plexus::daemon
