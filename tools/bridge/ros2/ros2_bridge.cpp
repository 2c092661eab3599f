#include "ros2_bridge.hpp"

#include <cstdlib>
#include <map>
#include <memory>
#include <set>

#include <spdlog/spdlog.h>

#include "counter_reporter.hpp"
#include "mapping.hpp"
#include "outbound.hpp"
#include "ros2_convert.hpp"
#include "ros2_qos.hpp"
#include "ros2_types.hpp"

namespace plexus::bridge {

namespace {

using ros2::Ros2Type;

/// A DDS entity deleted with its owner's lifetime (the participant deletes all it made).
struct Participant {
    dds_entity_t handle = 0;
    ~Participant() {
        if (handle > 0)
            dds_delete(handle);
    }
};

/// A mapping checked against what the bridge knows: its type, DDS topic name and QoS.
struct Ros2Mapping {
    std::string ros_topic;  ///< "/chatter"
    std::string dds_topic;  ///< "rt/chatter"
    std::string port;
    const Ros2Type* type = nullptr;
    ros2::Qos qos;
};

const Ros2Type& require_type(const std::string& name, const std::string& where) {
    if (const auto* type = ros2::find_type(name))
        return *type;
    std::string known;
    for (const auto& each : ros2::type_names())
        known += (known.empty() ? "" : ", ") + each;
    throw UsageError(where + ": unknown ROS 2 type '" + name + "'; plexus-bridge knows " + known);
}

Ros2Mapping checked(const std::string& text, const std::string& flag, bool inbound,
                    const ros2::Qos& defaults) {
    const auto mapping = parse_mapping(text, flag, true);
    const std::string where = flag + " '" + text + "'";
    Ros2Mapping out;
    out.ros_topic = inbound ? mapping.from : mapping.to;
    out.port = inbound ? mapping.to : mapping.from;
    // TYPE may carry the mapping's own QoS after commas: std_msgs/msg/String,best-effort,depth=1.
    const auto comma = mapping.type.find(',');
    out.type = &require_type(mapping.type.substr(0, comma), where);
    out.qos = comma == std::string::npos ? defaults
                                         : ros2::parse_qos(mapping.type.substr(comma + 1), defaults, where);
    out.dds_topic = ros2::dds_topic_name(out.ros_topic, where);
    require_port(out.port, where);
    return out;
}

int domain_of(const Ros2Options& options) {
    if (options.domain >= 0)
        return options.domain;
    const char* text = std::getenv("ROS_DOMAIN_ID");
    if (!text || !*text)
        return 0;
    char* end = nullptr;
    const long domain = std::strtol(text, &end, 10);
    if (*end != '\0' || domain < 0 || domain > 232)
        throw UsageError(std::string("ROS_DOMAIN_ID '") + text + "' is not a domain id (0 to 232)");
    return static_cast<int>(domain);
}

std::string dds_error(dds_return_t code) {
    return dds_strretcode(code < 0 ? -code : code);
}

/// A ROS 2 topic read into a Plexus port.
struct Inbound {
    Ros2Mapping mapping;
    dds_entity_t reader = 0;
    Port port;
    PortCounters counters;
};

dds_entity_t topic_for(dds_entity_t participant, const Ros2Mapping& mapping) {
    const dds_entity_t topic =
        dds_create_topic(participant, mapping.type->descriptor, mapping.dds_topic.c_str(), nullptr, nullptr);
    if (topic < 0)
        throw Error(ErrorCode::refused,
                    "cannot make the DDS topic " + mapping.dds_topic + ": " + dds_error(topic));
    return topic;
}

/// Takes what `inbound`'s reader holds and writes each sample into its port.
void pass_samples(Inbound& inbound) {
    constexpr std::size_t batch = 16;
    void* samples[batch] = {nullptr};
    dds_sample_info_t infos[batch];
    const dds_return_t taken = dds_take(inbound.reader, samples, infos, batch, batch);
    if (taken < 0) {
        inbound.counters.dropped("not_received", "dds_take: " + dds_error(taken));
        return;
    }
    for (dds_return_t i = 0; i < taken; ++i) {
        if (!infos[i].valid_data)
            continue;  // a writer went away or disposed an instance: nothing to pass on
        try {
            inbound.port.write(ros2::to_value(samples[i], *inbound.mapping.type->layout));
            inbound.counters.passed();
        } catch (const std::exception& error) {
            inbound.counters.dropped("not_delivered", error.what());
        }
    }
    dds_return_loan(inbound.reader, samples, taken);
}

}  // namespace

CLI::App* add_ros2_command(CLI::App& app, Ros2Options& options) {
    auto* command = app.add_subcommand("ros2",
                                       "ROS 2 topics to Plexus ports and back, over Cyclone DDS with ROS 2's "
                                       "conventions (topic rt/NAME, type "
                                       "pkg::msg::dds_::Name_). TYPE may end with the mapping's own QoS: "
                                       "std_msgs/msg/String,best-effort,transient-local,depth=5.");
    std::string types;
    for (const auto& name : ros2::type_names())
        types += (types.empty() ? "" : ", ") + name;
    command->footer("Types it knows (docs/BRIDGES.md: how each maps to a Plexus value): " + types +
                    ". Example: plexus-bridge ros2 --in /chatter=/ros/chatter:std_msgs/msg/String --out "
                    "/robot/cmd_vel=/cmd_vel:geometry_msgs/msg/Twist");
    command->add_option("--domain", options.domain, "the ROS 2 domain id (default: $ROS_DOMAIN_ID, else 0)")
        ->check(CLI::Range(0, 232));
    command->add_option("--in", options.in, "ROS_TOPIC=PORT:TYPE: a ROS 2 topic into a Plexus port");
    command->add_option("--out", options.out, "PORT=ROS_TOPIC:TYPE: a Plexus port out to a ROS 2 topic");
    command
        ->add_option("--reliability", options.reliability,
                     "reliable or best-effort (every mapping's default)")
        ->check(CLI::IsMember({"reliable", "best-effort"}))
        ->capture_default_str();
    command->add_option("--durability", options.durability, "volatile or transient-local")
        ->check(CLI::IsMember({"volatile", "transient-local"}))
        ->capture_default_str();
    command->add_option("--depth", options.depth, "history depth (keep last N)")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    return command;
}

int run_ros2(const Ros2Options& options, const StopCheck& stop) {
    if (options.in.empty() && options.out.empty())
        throw UsageError(
            "ros2: nothing to bridge; give --in ROS_TOPIC=PORT:TYPE or --out PORT=ROS_TOPIC:TYPE");
    const ros2::Qos defaults = ros2::parse_qos(
        options.reliability + "," + options.durability + ",depth=" + std::to_string(options.depth), {},
        "ros2");
    std::vector<Ros2Mapping> ins;
    std::vector<Ros2Mapping> outs;
    std::vector<std::string> ports;
    for (const auto& text : options.in) {
        ins.push_back(checked(text, "--in", true, defaults));
        ports.push_back(ins.back().port);
    }
    for (const auto& text : options.out) {
        outs.push_back(checked(text, "--out", false, defaults));
        ports.push_back(outs.back().port);
    }
    require_distinct_ports(ports, "ros2");
    const int domain = domain_of(options);

    Participant participant;
    participant.handle = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant.handle < 0)
        throw Error(ErrorCode::refused, "cannot join DDS domain " + std::to_string(domain) + ": " +
                                            dds_error(participant.handle));

    Client client;
    std::vector<std::unique_ptr<Inbound>> inbounds;
    std::vector<std::unique_ptr<Outbound>> outbounds;
    CounterReporter reporter;  // after the ports: destroyed (stopped) before them
    const dds_entity_t waitset = dds_create_waitset(participant.handle);
    for (auto& mapping : ins) {
        const dds_entity_t topic = topic_for(participant.handle, mapping);
        // The bridge's own writers' samples are not read back: it never re-publishes what it sent.
        const auto qos = ros2::reader_qos(mapping.qos);
        const dds_entity_t reader = dds_create_reader(participant.handle, topic, qos.get(), nullptr);
        if (reader < 0)
            throw Error(ErrorCode::refused, "cannot read " + mapping.dds_topic + ": " + dds_error(reader));
        auto inbound = std::unique_ptr<Inbound>(new Inbound{mapping, reader,
                                                            client.open(mapping.port, inbound_port_options()),
                                                            PortCounters(mapping.port, mapping.dds_topic)});
        const dds_entity_t readable = dds_create_readcondition(reader, DDS_ANY_STATE);
        dds_waitset_attach(waitset, readable, static_cast<dds_attach_t>(inbounds.size()));
        reporter.add(inbound->port, inbound->counters);
        spdlog::info("ros2: {} ({}) -> {}", mapping.dds_topic, mapping.type->dds_name, mapping.port);
        inbounds.push_back(std::move(inbound));
    }

    for (auto& mapping : outs) {
        const dds_entity_t topic = topic_for(participant.handle, mapping);
        const auto qos = ros2::writer_qos(mapping.qos);
        const dds_entity_t writer = dds_create_writer(participant.handle, topic, qos.get(), nullptr);
        if (writer < 0)
            throw Error(ErrorCode::refused, "cannot write " + mapping.dds_topic + ": " + dds_error(writer));
        // What this bridge injected from the same topic must not go back to it.
        std::set<std::string> loops;
        for (const auto& in : ins) {
            if (in.dds_topic == mapping.dds_topic)
                loops.insert(in.port);
        }
        auto outbound = std::make_unique<Outbound>(client, mapping.port, mapping.dds_topic, loops);
        const auto* layout = mapping.type->layout;
        outbound->start([writer, layout, builder = std::make_shared<ros2::SampleBuilder>(),
                         sample = std::make_shared<std::vector<char>>(layout->size)](const Received& message,
                                                                                     PortCounters& counters) {
            const auto error = builder->fill(message.data, *layout, sample->data());
            if (!error.empty()) {
                builder->clear();
                counters.dropped("not_converted", error);
                return;
            }
            const dds_return_t written = dds_write(writer, sample->data());
            builder->clear();
            if (written < 0)
                counters.dropped("not_delivered", "dds_write: " + dds_error(written));
            else
                counters.passed();
        });
        reporter.add(outbound->port(), outbound->counters());
        spdlog::info("ros2: {} -> {} ({})", mapping.port, mapping.dds_topic, mapping.type->dds_name);
        outbounds.push_back(std::move(outbound));
    }
    reporter.start();
    spdlog::info("ros2: bridging on DDS domain {}", domain);

    constexpr std::size_t most = 64;
    dds_attach_t triggered[most];
    while (!stop()) {
        const dds_return_t count = dds_waitset_wait(waitset, triggered, most, DDS_MSECS(100));
        for (dds_return_t i = 0; i < count && i < static_cast<dds_return_t>(most); ++i)
            pass_samples(*inbounds.at(static_cast<std::size_t>(triggered[i])));
    }
    reporter.stop();
    for (auto& outbound : outbounds)
        outbound->stop();
    spdlog::info("ros2: stopping");
    return 0;
}

}  // namespace plexus::bridge
