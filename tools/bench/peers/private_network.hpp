#pragma once
// A network of the calling thread's own, for a Cyclone DDS run: a fresh network namespace
// (unshare(CLONE_NEWNET)) holding only a loopback interface, up and marked multicast-capable.
//
// Why a namespace and not a CYCLONEDDS_URI that pins DDS to 127.0.0.1: DDS discovers by
// multicast, and a run must neither send one packet on this machine's real interfaces nor meet
// another DDS program (the ROS 2 bridge tests, another engineer's run) in its domain; a namespace
// guarantees both whatever Cyclone's configuration says, while Cyclone keeps its default
// configuration: it finds one multicast-capable interface and discovers by multicast on it, as
// on a robot's computer. Loopback is where two processes of one machine meet anyway: unicast to the
// machine's own address never reaches its network card (multicast there also goes out on the wire,
// which this namespace spares DDS; on a robot it costs little).
//
// Why unshare and not a named namespace (`ip netns add`, as `plexus-bench hosts` does): nothing to
// remove. The namespace lives as long as a thread or process in it: the run process and the far
// ends it starts. Threads and children made after the call are inside; none outlives the run.
//
// Needs root (CAP_SYS_ADMIN), as the bench's other network scenarios do.

namespace plexus::bench::peers {

/// Moves the calling thread into a new network namespace with loopback up and multicast on.
/// Call it before anything else in the process makes a socket or a DDS entity. Throws (saying
/// that root is needed, when that is why) if it cannot.
void enter_private_network();

}  // namespace plexus::bench::peers
