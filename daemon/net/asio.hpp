#pragma once
// Threading: declarations only. Every daemon object lives on one io_context run by one thread at a
// time (monitor/loop_stand_in.hpp).

#include <boost/asio.hpp>
#include <boost/asio/experimental/awaitable_operators.hpp>

namespace plexus::daemon {

namespace asio = boost::asio;
using Socket = asio::generic::stream_protocol::socket;
template <typename T = void>
using Task = asio::awaitable<T>;

/// Completion token that returns (error_code, values...) instead of throwing.
inline constexpr auto use_nothrow = asio::as_tuple(asio::use_awaitable);

}  // namespace plexus::daemon
