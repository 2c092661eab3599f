#pragma once
// How a bridge learns that it should stop: polled at least every 100 ms by its loops.
#include <functional>

namespace plexus::bridge {

using StopCheck = std::function<bool()>;

}  // namespace plexus::bridge
