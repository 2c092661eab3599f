#include "carrier_rules.hpp"

namespace plexus::daemon::arbitration {

bool arbitration_only(const proto::Clause& clause) {
    return clause.modifier == "portmonitor" && !clause.find("file") &&
           (clause.find("constraint") || clause.find("aux"));
}

proto::Status configure_member(Member& member, const proto::Carrier& carrier) {
    bool has_priority = false;
    for (const auto& clause : carrier.clauses) {
        if (clause.modifier == "priority") {
            if (clause.side != proto::Side::recv)
                return proto::Error{
                    "send.priority: stimulation arbitrates an input port, so it is a recv. "
                    "clause (recv.priority)"};
            if (has_priority)
                return proto::Error{"two recv.priority clauses on one connection"};
            has_priority = true;
            auto params = PriorityParams::from_clause(clause);
            if (!params)
                return params.error();
            member.set_priority(*params);
            continue;
        }
        if (clause.modifier != "portmonitor")
            continue;
        for (const auto& param : clause.params) {
            if (param.key != "constraint" && param.key != "aux")
                continue;
            if (param.key == "constraint" && clause.side == proto::Side::send)
                continue;  // a route constraint, over the source port's events (route_constraint)
            if (clause.side != proto::Side::recv)
                return proto::Error{"'" + param.key + "' in a " + proto::side_name(clause.side) +
                                    ".portmonitor clause: arbitration happens in the input port, so it "
                                    "belongs to a recv. clause"};
            if (param.key == "aux") {
                if (param.value)
                    return proto::Error{"portmonitor key 'aux' is a flag and takes no value"};
                member.aux = true;
                continue;
            }
            if (member.constraint)
                return proto::Error{"two constraints on one connection ('" + member.constraint->text() +
                                    "' and '" + param.value.value_or("") + "'): combine them with and/or"};
            auto parsed = Constraint::parse(param.value.value_or(""));
            if (!parsed)
                return parsed.error();
            member.constraint = std::move(*parsed);
        }
    }
    return proto::Ok{};
}

proto::Result<std::optional<Constraint>> route_constraint(const proto::Carrier& carrier) {
    std::optional<Constraint> found;
    for (const auto& clause : carrier.clauses) {
        if (clause.side != proto::Side::send || clause.modifier != "portmonitor")
            continue;
        for (const auto& param : clause.params) {
            if (param.key != "constraint")
                continue;
            if (found)
                return proto::Error{"two send-side constraints on one connection ('" + found->text() +
                                    "' and '" + param.value.value_or("") + "'): combine them with and/or"};
            auto parsed = Constraint::parse(param.value.value_or(""));
            if (!parsed)
                return parsed.error();
            found = std::move(*parsed);
        }
    }
    return found;
}

}  // namespace plexus::daemon::arbitration
