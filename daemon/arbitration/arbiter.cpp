#include "arbiter.hpp"

#include <mutex>

#include <algorithm>

namespace plexus::daemon::arbitration {

Member::~Member() {
    if (!joined_)
        return;
    // The last reference may go on a monitor worker: the arbiter is shared, so under its lock.
    std::lock_guard lock(arbiter_->mutex());
    arbiter_->leave(*this);
}

bool Arbiter::constraint_value(const Member& member, double now) const {
    if (!member.constraint)
        return true;
    return member.constraint->evaluate([&](const std::string& name) { return events_.has(name, now); });
}

Arbiter::Verdict Arbiter::admit(Member& member, double now) {
    if (!constraint_value(member, now)) {
        ++member.dropped_by_constraint;
        return Verdict::constraint;
    }
    if (member.stimulus) {
        member.stimulus->stimulate(now);
        if (member.aux)
            return Verdict::auxiliary;  // it stimulated; the others' selections will see it
        // The selection of priority_state(), without building the state for people.
        const std::size_t n = stimulated_.size();
        active_.resize(n);
        for (std::size_t i = 0; i < n; ++i)
            active_[i] = stimulated_[i]->stimulus->active(now);
        std::optional<std::size_t> winner;
        if (solve_outputs_into(weights_, active_, bias_, matrix_, outputs_))
            winner = select_winner(outputs_, auxiliary_);
        if (!winner || stimulated_[*winner] != &member) {
            ++member.dropped_by_priority;
            return Verdict::priority;
        }
        return Verdict::deliver;
    }
    return member.aux ? Verdict::auxiliary : Verdict::deliver;
}

const char* Arbiter::verdict_name(Verdict verdict) {
    switch (verdict) {
        case Verdict::constraint:
            return "constraint";
        case Verdict::priority:
            return "priority";
        case Verdict::auxiliary:
            return "auxiliary";
        case Verdict::deliver:
            break;
    }
    return "delivered";
}

PriorityState Arbiter::priority_state() const {
    PriorityState state;
    state.members = stimulated_;
    const double now = clock_.now();
    const std::size_t n = stimulated_.size();
    for (std::size_t i = 0; i < n; ++i) {
        const Member& member = *stimulated_[i];
        state.level.push_back(member.stimulus->level(now));
        state.active.push_back(member.stimulus->active(now));
    }
    auto outputs = solve_outputs(weights_, state.active, bias_);
    if (!outputs) {
        state.error = outputs.error().message;
        state.output.assign(n, 0.0);
        return state;
    }
    state.output = std::move(*outputs);
    state.winner = select_winner(state.output, auxiliary_);
    return state;
}

std::vector<const Member*> Arbiter::stimulated(const Member* candidate) const {
    std::vector<const Member*> list;
    for (const Member* member : members_) {
        if (member->priority)
            list.push_back(member);
    }
    if (candidate && candidate->priority && !candidate->joined_)
        list.push_back(candidate);
    return list;
}

std::vector<std::vector<double>> Arbiter::weight_matrix(const std::vector<const Member*>& members) {
    const std::size_t n = members.size();
    std::vector<std::vector<double>> weights(n, std::vector<double>(n, 0.0));
    for (std::size_t j = 0; j < n; ++j) {
        for (const auto& [source, weight] : members[j]->priority->ex) {
            for (std::size_t i = 0; i < n; ++i) {
                if (i != j && members[i]->source() == source)
                    weights[j][i] = weight;
            }
        }
    }
    return weights;
}

proto::Status Arbiter::check_weights(const Member& candidate) const {
    if (!candidate.priority)
        return proto::Ok{};
    const auto members = stimulated(&candidate);
    const auto weights = weight_matrix(members);
    const std::size_t n = members.size();
    std::vector<double> bias(n);
    for (std::size_t i = 0; i < n; ++i)
        bias[i] = members[i]->priority->bs;
    // Every subset of active connections while that stays small (2^12 solves of 12 x 12); past
    // that, only the one where all are active.
    constexpr std::size_t max_exhaustive = 12;
    const bool exhaustive = n <= max_exhaustive;
    const std::uint64_t subsets = exhaustive ? (std::uint64_t{1} << n) : 1;
    for (std::uint64_t bits = 0; bits < subsets; ++bits) {
        std::vector<bool> active(n, true);
        for (std::size_t i = 0; exhaustive && i < n; ++i)
            active[i] = (bits & (std::uint64_t{1} << i)) != 0;
        if (solve_outputs(weights, active, bias))
            continue;
        std::string names;
        for (std::size_t i = 0; i < n; ++i) {
            if (active[i])
                names += (names.empty() ? "" : ", ") + members[i]->source();
        }
        return proto::Error{"inconsistent weights: with the connections from " + names +
                            " active, the system (I - X*A^T) y = X*beta is singular (check the ex. weights)"};
    }
    return proto::Ok{};
}

bool Arbiter::uses_constraints(const Member* candidate) const {
    if (candidate && candidate->constraint)
        return true;
    return std::any_of(members_.begin(), members_.end(),
                       [](const Member* m) { return m->constraint.has_value(); });
}

std::vector<Arbiter::Pair> Arbiter::overlaps(const Member* candidate) const {
    std::vector<const Member*> members;
    for (const Member* member : members_) {
        if (!member->aux)
            members.push_back(member);
    }
    std::optional<std::size_t> only;
    if (candidate && !candidate->joined_) {
        if (candidate->aux)
            return {};
        only = members.size();
        members.push_back(candidate);
    }
    std::vector<Rule> rules;
    for (const Member* member : members)
        rules.push_back({member->source(), member->constraint ? &*member->constraint : nullptr,
                         member->priority.has_value()});
    std::vector<Pair> pairs;
    for (auto& overlap : find_overlaps(rules, only))
        pairs.push_back(
            {rules[overlap.first].label, rules[overlap.second].label, std::move(overlap.witness)});
    return pairs;
}

void Arbiter::join(Member& member) {
    if (member.joined_)
        return;
    member.joined_ = true;
    members_.push_back(&member);
    refresh_weights();
}

void Arbiter::leave(Member& member) {
    std::erase(members_, &member);
    member.joined_ = false;
    refresh_weights();
}

void Arbiter::refresh_weights() {
    stimulated_ = stimulated(nullptr);
    weights_ = weight_matrix(stimulated_);
    bias_.clear();
    auxiliary_.clear();
    for (const Member* member : stimulated_) {
        bias_.push_back(member->priority->bs);
        auxiliary_.push_back(member->aux);
    }
}

}  // namespace plexus::daemon::arbitration
