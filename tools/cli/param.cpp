// plexus param get|set SRC DST [KEY=VALUE...]: talks to the monitors on one connection.
#include <iostream>

#include "commands.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/port_name.hpp"
#include "replies.hpp"

namespace plexus::cli {

namespace {

/// KEY=VALUE, VALUE read as JSON when it parses (0.8, true, [1,2]) and as a string otherwise.
Value parse_assignments(const std::vector<std::string>& assignments) {
    Value values = Value::object();
    for (const auto& assignment : assignments) {
        const auto equals = assignment.find('=');
        if (equals == std::string::npos || equals == 0)
            throw Error(ErrorCode::usage, "'" + assignment + "' is not KEY=VALUE");
        const std::string text = assignment.substr(equals + 1);
        Value value = Value::parse(text, nullptr, false);
        const std::string key = assignment.substr(0, equals);
        if (auto shallow = proto::check_value_depth(value, "the value of " + key); !shallow)
            throw Error(ErrorCode::usage, shallow.error().message);
        values[key] = value.is_discarded() ? Value(text) : value;
    }
    return values;
}

}  // namespace

int param(const Common& common, const std::string& action, const std::string& source,
          const std::string& destination, const std::vector<std::string>& assignments) {
    for (const auto& name : {source, destination}) {
        if (auto error = proto::port_name_error(name))
            throw Error(ErrorCode::usage, *error);
    }
    if (action == "get" && !assignments.empty())
        throw Error(ErrorCode::usage, "param get takes no KEY=VALUE");
    if (action == "set" && assignments.empty())
        throw Error(ErrorCode::usage, "param set needs at least one KEY=VALUE");
    proto::ParamRequest asked;
    asked.action = action;
    asked.source = source;
    asked.destination = destination;
    if (action == "set")
        asked.values = parse_assignments(assignments);
    plexus::Client client({common.socket});
    const auto reply = read_as<proto::ParamReply>(client.request(asked.encode()));
    // The documented output: the list of monitors, each {"param", "script", "side"}.
    std::cout << proto::ParamReply{reply.monitors}.encode()["monitors"].dump() << '\n';
    return 0;
}

}  // namespace plexus::cli
