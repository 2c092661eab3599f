// The systems `plexus-bench peers` knows: Plexus always, the peers when built with them; and the
// far ends of the brokerless peers.
#include "pubsub.hpp"

#ifdef PLEXUS_BENCH_PEERS
#include <iostream>

#include "peer_systems.hpp"
#endif

namespace plexus::bench::peers {

System plexus_system();        // plexus_pubsub.cpp
System plexus_loans_system();  // plexus_pubsub.cpp: the same broker, bytes lent in shared memory

std::vector<System> all_systems() {
    std::vector<System> systems{plexus_system(), plexus_loans_system()};
#ifdef PLEXUS_BENCH_PEERS
    systems.push_back(mosquitto_system());
    systems.push_back(nats_system());
    systems.push_back(zeromq_system());
    systems.push_back(redis_system());
    systems.push_back(cyclonedds_system());
    systems.push_back(cyclonedds_best_effort_system());
    systems.push_back(iceoryx_system());
#endif
    return systems;
}

#ifdef PLEXUS_BENCH_PEERS
int run_far_end(const FarEndOptions& options) {
    try {
        if (options.system == "iceoryx")
            return run_iceoryx_far_end(options);
        return run_cyclonedds_far_end(options);  // refuses a name that is not one of its two
    } catch (const std::exception& e) {
        std::cerr << "plexus-bench peer-far-end: " << options.system << " " << options.role << " on "
                  << options.topic << ": " << e.what() << '\n';
        return 1;
    }
}
#endif

bool peers_built() {
#ifdef PLEXUS_BENCH_PEERS
    return true;
#else
    return false;
#endif
}

}  // namespace plexus::bench::peers
