#include "carrier_monitors.hpp"

#include "../arbitration/carrier_rules.hpp"
#include "script_library.hpp"

namespace plexus::daemon::monitor {

proto::Result<MonitorSpec> spec_of_clause(const proto::Clause& clause, const proto::Carrier& carrier,
                                          const std::string& source, const std::string& destination) {
    MonitorSpec spec;
    spec.side = clause.side;
    spec.source = source;
    spec.destination = destination;
    spec.carrier = carrier.text();
    std::string file;
    for (const auto& param : clause.params) {
        const std::string value = param.value.value_or("");
        if (param.key == "type") {
            if (value != "lua" && value != "so")
                return proto::Error{"portmonitor type '" + value +
                                    "' is not supported (type.lua or type.so)"};
            spec.type = value == "so" ? MonitorType::plugin : MonitorType::lua;
        } else if (param.key == "file") {
            file = value;
        } else if (param.key == "onerror") {
            if (value == "drop")
                spec.on_error = OnError::drop;
            else if (value == "pass")
                spec.on_error = OnError::pass;
            else
                return proto::Error{"onerror." + value + ": expected onerror.drop or onerror.pass"};
        } else if (param.key == "constraint" || param.key == "aux") {
            continue;  // the port's arbitration reads these (arbitration/carrier_rules)
        } else {
            spec.options[param.key] = value;
        }
    }
    if (file.empty())
        return proto::Error{"portmonitor clause without file.NAME"};
    spec.script.name = file;
    return spec;
}

proto::Result<std::shared_ptr<MonitorChain>> build_carrier_chain(
    const proto::Carrier& carrier, proto::Side side, const std::string& source,
    const std::string& destination, const std::shared_ptr<arbitration::Member>& member,
    const ChainPlaces& places, MonitorHost& host) {
    auto chain = std::make_shared<MonitorChain>();
    for (const auto& clause : carrier.clauses) {
        if (clause.side != side || clause.modifier != "portmonitor" || arbitration::arbitration_only(clause))
            continue;
        auto spec = spec_of_clause(clause, carrier, source, destination);
        if (!spec)
            return spec.error();
        auto script = spec->type == MonitorType::plugin
                          ? find_plugin(spec->script.name, places.monitor_lib_dirs)
                          : find_script(spec->script.name, places.script_dirs);
        if (!script)
            return script.error();
        spec->script = std::move(*script);
        if (side == proto::Side::recv)
            spec->member = member;
        auto created = Monitor::create(std::move(*spec), places.policy, host);
        if (!created)
            return created.error();
        chain->monitors.push_back(std::move(*created));
    }
    if (chain->monitors.empty())
        return std::shared_ptr<MonitorChain>{};
    return chain;
}

}  // namespace plexus::daemon::monitor
