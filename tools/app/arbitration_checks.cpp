// The arbitration of every port that several of the application's connections feed, checked as
// the daemon would check it connection by connection, in the file's order (DESIGN, "Arbitration
// by events and constraints" and "Arbitration by stimulation").
#include <memory>

#include "app_checks.hpp"
#include "arbitration/carrier_rules.hpp"
#include "arbitration/clock.hpp"
// The daemon's words for an overlap's witness (header only), so check and connect say the same.
#include "inspect/overlap_text.hpp"

namespace plexus::app {

namespace arbitration = daemon::arbitration;

namespace {

/// The connections of the file from `source` into `destination` (one, after check_duplicates).
std::string label_of(const std::vector<const AppConnection*>& into, const std::string& source) {
    for (const auto* connection : into) {
        if (connection->source == source)
            return connection->label();
    }
    return source;
}

}  // namespace

void check_arbitration(const App& app, const std::map<std::size_t, proto::Carrier>& carriers,
                       CheckReport& report) {
    std::map<std::string, std::vector<const AppConnection*>> by_destination;
    for (const auto& connection : app.connections) {
        if (carriers.count(connection.index))
            by_destination[connection.destination].push_back(&connection);
    }
    for (const auto& [destination, into] : by_destination) {
        if (into.size() < 2)
            continue;
        const std::string where = app.file + ": connections into " + destination + ": ";
        arbitration::ManualClock clock;
        auto arbiter = std::make_shared<arbitration::Arbiter>(clock);
        std::vector<std::unique_ptr<arbitration::Member>> members;  // destroyed before the arbiter
        for (const auto* connection : into) {
            auto member = std::make_unique<arbitration::Member>(arbiter, connection->source);
            if (!arbitration::configure_member(*member, carriers.at(connection->index)))
                continue;  // reported by check_carriers
            // As `connect` does for each new connection: the weights with it must stay solvable.
            if (auto weights = arbiter->check_weights(*member); !weights) {
                report.problems.push_back(where + connection->label() +
                                          ": \"carrier\": " + weights.error().message);
                continue;
            }
            arbiter->join(*member);
            members.push_back(std::move(member));
        }
        // Like connect, only ports that use constraints are held to the one-deliverer rule: plain
        // fan-in (several writers into one reader) is ordinary publish-subscribe.
        if (!arbiter->uses_constraints())
            continue;
        for (const auto& pair : arbiter->overlaps()) {
            report.problems.push_back(where + label_of(into, pair.first) + " and " +
                                      label_of(into, pair.second) + " can both deliver, " +
                                      daemon::describe_witness(pair.witness) +
                                      " (at most one non-auxiliary connection's constraint may be true)");
        }
    }
}

}  // namespace plexus::app
