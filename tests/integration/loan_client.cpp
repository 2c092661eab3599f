// plexus-loan-client: a component of the loans tests (loans_test.cpp) that a test kills -9 while
// it holds shared memory. `write PORT DST SIZE`: sends loans of SIZE bytes from PORT (connected to
// DST) for ever, always holding two more loans not sent yet. `view PORT`: reads PORT with
// read_view and keeps every view. Each prints one line once it holds what it holds
// ("writing", "holding N") and runs until killed.
#include <chrono>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "plexus/client.hpp"

int main(int argc, char** argv) {
    if (argc < 4) {
        std::cerr << "usage: plexus-loan-client SOCKET write PORT DST SIZE | SOCKET view PORT\n";
        return 2;
    }
    const std::string socket = argv[1];
    const std::string mode = argv[2];
    try {
        plexus::Client client({socket});
        auto port = client.open(argv[3]);
        if (mode == "write" && argc >= 6) {
            client.connect(port.name(), argv[4]);
            const std::size_t size = std::stoul(argv[5]);
            std::vector<plexus::Loan> held;
            bool said = false;
            for (std::uint8_t round = 0;; ++round) {
                held.push_back(port.loan(size));
                std::memset(held.back().bytes().data(), round, size);
                if (held.size() > 2) {
                    port.send_loan(std::move(held.front()));
                    held.erase(held.begin());
                    if (!said) {
                        std::cout << "writing" << std::endl;
                        said = true;
                    }
                }
                std::this_thread::sleep_for(std::chrono::milliseconds(2));
            }
        }
        if (mode == "view") {
            std::vector<plexus::MessageView> views;
            for (;;) {
                if (auto view = port.read_view(std::chrono::milliseconds(100))) {
                    views.push_back(std::move(*view));
                    std::cout << "holding " << views.size() << std::endl;
                }
            }
        }
        std::cerr << "plexus-loan-client: unknown mode " << mode << "\n";
        return 2;
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-loan-client: " << e.what() << "\n";
        return static_cast<int>(e.code());
    }
}
