#pragma once
// The loop of the simulated controllers (gaze, arm, hand): read a message from one port, turn it
// into a command, write that on another port, until SIGINT/SIGTERM. Each controller is this loop
// plus its conversion.
//
// The input port keeps only the newest 2 messages (policy latest): a controller that fell behind
// forwards the latest target, never a backlog of old ones. Reads wait at most 100 ms so that a stop
// request is seen promptly even when nothing arrives.
#include <chrono>
#include <functional>
#include <iostream>
#include <string>

#include "malformed_counter.hpp"
#include "plexus/client.hpp"
#include "stop_signal.hpp"
#include "world_messages.hpp"

namespace plexus::sim {

/// Turns one input message into the output message, or says why it cannot.
using Conversion = std::function<Parsed<Value>(const Value&)>;

inline int run_forwarder(const std::string& program, const std::string& in, const std::string& out,
                         const Conversion& convert) {
    install_stop_handlers();
    try {
        Client client;
        PortOptions latest;
        latest.policy = QueuePolicy::latest;
        latest.capacity = 2;
        Port input = client.open(in, latest);
        Port output = client.open(out);
        MalformedCounter malformed(program, in);
        std::uint64_t forwarded = 0;
        while (!stop_requested()) {
            const auto message = input.read(std::chrono::milliseconds(100));
            if (!message)
                continue;
            const auto converted = convert(message->data);
            if (!converted) {
                malformed.count(converted.error);
                continue;
            }
            output.write(*converted.value);
            ++forwarded;
        }
        malformed.summarize();
        std::cerr << program << ": forwarded " << forwarded << " messages\n";
        return 0;
    } catch (const Error& e) {
        std::cerr << program << ": " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
}

}  // namespace plexus::sim
