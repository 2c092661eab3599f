// A minimal Plexus component: opens an output and an input port, connects them, writes a few
// counted messages and reads them back. Run it where a plexusd is running (PLEXUS_SOCKET tells it
// where, if not the default): `./counter [COUNT]`. Exits 0 when every message came back in order.
#include <plexus/client.hpp>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
    const int count = argc > 1 ? std::atoi(argv[1]) : 3;
    try {
        plexus::Client client;  // the local daemon, at $PLEXUS_SOCKET or the per-user default
        plexus::Port out = client.open("/counter/out");
        plexus::Port in = client.open("/counter/in", {.policy = plexus::QueuePolicy::strict, .capacity = 16});
        client.connect("/counter/out", "/counter/in");

        for (int n = 1; n <= count; ++n)
            out.write({{"n", n}, {"text", "message " + std::to_string(n)}});

        for (int n = 1; n <= count; ++n) {
            auto message = in.read(std::chrono::seconds(5));
            if (!message || message->data["n"] != n) {
                std::cerr << "counter: expected message " << n << ", got "
                          << (message ? message->data.dump() : "nothing within 5 s") << '\n';
                return 1;
            }
            std::cout << "received " << message->data.dump() << " from " << message->envelope.source << '\n';
        }
        return 0;
    } catch (const plexus::Error& error) {  // e.g. no daemon running: the message says where it looked
        std::cerr << "counter: " << error.what() << '\n';
        return static_cast<int>(error.code());
    }
}
