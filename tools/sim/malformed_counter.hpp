#pragma once
// Counts the malformed messages of one input and logs them without flooding the log: the first ten
// each, then every hundredth, since a broken sender may write hundreds per second.
#include <cstdint>
#include <iostream>
#include <string>

namespace plexus::sim {

class MalformedCounter {
public:
    MalformedCounter(std::string program, std::string port)
        : program_(std::move(program)), port_(std::move(port)) {}

    void count(const std::string& why) {
        ++count_;
        if (count_ <= 10 || count_ % 100 == 0)
            std::cerr << program_ << ": " << port_ << ": malformed message ignored (" << count_
                      << " so far): " << why << '\n';
    }

    std::uint64_t total() const { return count_; }

    /// One line at exit, if anything was ignored.
    void summarize() const {
        if (count_ > 0)
            std::cerr << program_ << ": " << port_ << ": " << count_ << " malformed messages ignored\n";
    }

private:
    std::string program_;
    std::string port_;
    std::uint64_t count_ = 0;
};

}  // namespace plexus::sim
