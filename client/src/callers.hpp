#pragma once
// The ports Client::request opened to call other ports, by the port they call (calls.cpp).

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "plexus/client.hpp"

namespace plexus {

struct Client::Callers {
    std::mutex mutex;  ///< a leaf (LOCK_ORDER.md); held while a caller port is opened and connected
    std::map<std::string, std::unique_ptr<Port>> by_target;
};

}  // namespace plexus
