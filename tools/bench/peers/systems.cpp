// The systems `plexus-bench peers` knows: Plexus always, the peers when built with them.
#include "pubsub.hpp"

#ifdef PLEXUS_BENCH_PEERS
#include "peer_systems.hpp"
#endif

namespace plexus::bench::peers {

System plexus_system();  // plexus_pubsub.cpp

std::vector<System> all_systems() {
    std::vector<System> systems{plexus_system()};
#ifdef PLEXUS_BENCH_PEERS
    systems.push_back(mosquitto_system());
    systems.push_back(nats_system());
    systems.push_back(zeromq_system());
    systems.push_back(redis_system());
#endif
    return systems;
}

bool peers_built() {
#ifdef PLEXUS_BENCH_PEERS
    return true;
#else
    return false;
#endif
}

}  // namespace plexus::bench::peers
