#include "peer_limits.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

namespace plexus::daemon {

PeerLimits::Ticket::~Ticket() {
    limits_->closed(peer_, handshaking_);
}

void PeerLimits::Ticket::handshake_done() {
    if (!handshaking_)
        return;
    handshaking_ = false;
    limits_->handshake_done(peer_);
}

void PeerLimits::Ticket::proof_failed(Clock::time_point now) {
    limits_->proof_failed(peer_, now);
}

void PeerLimits::log_refusal(const std::string& who, const std::string& peer, Refusal refusal,
                             Clock::time_point now) {
    std::uint64_t unsaid = 0;
    {
        std::lock_guard lock(mutex_);
        if (now - last_logged_ < std::chrono::seconds(1)) {
            ++not_logged_;
            return;
        }
        last_logged_ = now;
        unsaid = std::exchange(not_logged_, 0);
    }
    spdlog::warn("{}refused a connection from {}: it has {} ({} more refused since the last such line)", who,
                 peer, explain(refusal), unsaid);
}

PeerLimits::Admission PeerLimits::admit(const std::string& peer, Clock::time_point now) {
    std::lock_guard lock(mutex_);
    auto it = peers_.try_emplace(peer).first;
    Peer& counted = it->second;
    while (!counted.failures.empty() && now - counted.failures.front() >= failure_window)
        counted.failures.pop_front();
    Refusal refusal = Refusal::none;
    if (config_.failed_proofs > 0 && counted.failures.size() >= config_.failed_proofs)
        refusal = Refusal::failed_proofs;
    else if (counted.open >= config_.connections)
        refusal = Refusal::connections;
    else if (counted.handshaking >= config_.handshakes)
        refusal = Refusal::handshakes;
    if (refusal != Refusal::none) {
        tidy(it, now);
        return {nullptr, refusal};
    }
    ++counted.open;
    ++counted.handshaking;
    return {std::make_unique<Ticket>(shared_from_this(), peer), Refusal::none};
}

std::string PeerLimits::explain(Refusal refusal) const {
    switch (refusal) {
        case Refusal::none:
            return "admitted";
        case Refusal::connections:
            return std::to_string(config_.connections) + " connections open (peer_connections)";
        case Refusal::handshakes:
            return std::to_string(config_.handshakes) +
                   " connections not through their handshake (peer_handshakes)";
        case Refusal::failed_proofs:
            return std::to_string(config_.failed_proofs) +
                   " failed proofs of the secret in the last minute (peer_failed_proofs)";
    }
    return "?";
}

std::size_t PeerLimits::peers() const {
    std::lock_guard lock(mutex_);
    return peers_.size();
}

void PeerLimits::handshake_done(const std::string& peer) {
    std::lock_guard lock(mutex_);
    if (auto it = peers_.find(peer); it != peers_.end() && it->second.handshaking > 0)
        --it->second.handshaking;
}

void PeerLimits::proof_failed(const std::string& peer, Clock::time_point now) {
    std::lock_guard lock(mutex_);
    auto it = peers_.find(peer);
    if (it == peers_.end())
        return;  // a ticket's peer has an entry while the ticket lives
    auto& failures = it->second.failures;
    failures.push_back(now);
    while (failures.size() > std::max<std::size_t>(config_.failed_proofs, 1))
        failures.pop_front();  // only the last `failed_proofs` matter
}

void PeerLimits::closed(const std::string& peer, bool handshaking) {
    std::lock_guard lock(mutex_);
    auto it = peers_.find(peer);
    if (it == peers_.end())
        return;
    if (it->second.open > 0)
        --it->second.open;
    if (handshaking && it->second.handshaking > 0)
        --it->second.handshaking;
    tidy(it, Clock::now());
}

void PeerLimits::tidy(std::map<std::string, Peer>::iterator it, Clock::time_point now) {
    Peer& counted = it->second;
    while (!counted.failures.empty() && now - counted.failures.front() >= failure_window)
        counted.failures.pop_front();
    if (counted.open == 0 && counted.failures.empty())
        peers_.erase(it);
}

}  // namespace plexus::daemon
