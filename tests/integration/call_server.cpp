// plexus-call-server: a server for the calls tests (calls_test.cpp), a component of its own that a
// test can kill -9. Serves PORT: each call is answered with {"by": PORT, "request": VALUE} after
// --delay-ms; a request {"fail": "why"} fails the call with that reason. With --health, it also
// writes {"ok": true} to PORT/health every 50 ms while the file --health names exists, and
// {"ok": false} while it does not. Runs until killed.
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include "plexus/client.hpp"

int main(int argc, char** argv) {
    std::string socket;
    std::string port;
    std::string health;
    int delay_ms = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--socket" && i + 1 < argc)
            socket = argv[++i];
        else if (arg == "--delay-ms" && i + 1 < argc)
            delay_ms = std::atoi(argv[++i]);
        else if (arg == "--health" && i + 1 < argc)
            health = argv[++i];
        else
            port = arg;
    }
    if (port.empty()) {
        std::cerr << "usage: plexus-call-server [--socket PATH] [--delay-ms N] [--health FILE] PORT\n";
        return 2;
    }
    try {
        plexus::Client client({socket});
        auto service = client.serve(port, [&](const plexus::Received& request) -> plexus::Value {
            if (delay_ms > 0)
                std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));  // a slow server
            if (request.data.is_object() && request.data.contains("fail"))
                throw std::runtime_error(request.data["fail"].get<std::string>());
            return {{"by", port}, {"request", request.data}};
        });
        std::optional<plexus::Port> health_port;
        if (!health.empty())
            health_port.emplace(client.open(port + "/health"));
        std::cout << "serving " << port << std::endl;  // the test waits for this line
        for (;;) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            if (health_port)
                health_port->write(plexus::Value{{"ok", std::filesystem::exists(health)}});
        }
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-call-server: " << e.what() << "\n";
        return static_cast<int>(e.code());
    }
}
