#include "mqtt_bridge.hpp"

#include <cstdlib>
#include <memory>
#include <set>
#include <thread>

#include <mosquitto.h>
#include <spdlog/spdlog.h>

#include "broker_address.hpp"
#include "counter_reporter.hpp"
#include "mapping.hpp"
#include "mqtt_payload.hpp"
#include "mqtt_session.hpp"
#include "outbound.hpp"

namespace plexus::bridge {

CLI::App* add_mqtt_command(CLI::App& app, MqttOptions& options) {
    auto* command =
        app.add_subcommand("mqtt", "MQTT topics to Plexus ports and back (libmosquitto, MQTT v5)");
    command->add_option("--broker", options.broker, "the broker, HOST:PORT")->capture_default_str();
    command->add_option("--in", options.in,
                        "'TOPIC_PATTERN=PORT': MQTT messages into a Plexus port (+ and # allowed)");
    command->add_option("--out", options.out, "'PORT=TOPIC': a Plexus port's messages out to MQTT");
    command->add_option("--qos", options.qos, "QoS of subscriptions and publications")
        ->check(CLI::IsMember({0, 1}))
        ->capture_default_str();
    command->add_flag("--retain", options.retain, "publish retained on the --out topics");
    command
        ->add_option("--payload", options.payload,
                     "json: JSON text <-> values (other UTF-8 text: a string); raw: bytes <-> blobs")
        ->check(CLI::IsMember({"json", "raw"}))
        ->capture_default_str();
    command->add_flag("--envelope", options.envelope,
                      "inbound values are {\"topic\": T, \"payload\": V, \"retained\": B}");
    command->add_option("--id", options.id, "MQTT client id (default: a random one); unique per broker");
    command->add_option("--username,-u", options.username, "MQTT user name");
    command->add_option("--password,-P", options.password, "MQTT password (default: $MQTT_PASSWORD)");
    command->add_option("--cafile", options.cafile, "TLS: the CA certificates to check the broker with");
    command->add_option("--capath", options.capath, "TLS: a directory of CA certificates");
    command->add_option("--cert", options.cert, "TLS: this client's certificate");
    command->add_option("--key", options.key, "TLS: this client's private key");
    command->add_flag("--insecure", options.insecure, "TLS: do not check the broker's host name");
    command->add_option("--keepalive,-k", options.keepalive, "seconds between pings")
        ->check(CLI::Range(5, 65535))
        ->capture_default_str();
    command->add_option("--held", options.held, "publications held while the broker is away")
        ->check(CLI::Range(std::size_t{1}, std::size_t{1000000}))
        ->capture_default_str();
    return command;
}

namespace {

/// An --in mapping: the MQTT pattern and the Plexus port its messages are written to.
struct Inbound {
    Inbound(Client& client, std::string pattern_, const std::string& port_name)
        : pattern(std::move(pattern_)),
          port(client.open(port_name, inbound_port_options())),
          counters(port_name, "mqtt " + pattern) {}
    std::string pattern;
    Port port;
    PortCounters counters;
};

void require_topic(const std::string& topic, bool pattern, const std::string& where) {
    const auto rc =
        pattern ? mosquitto_sub_topic_check(topic.c_str()) : mosquitto_pub_topic_check(topic.c_str());
    if (rc != MOSQ_ERR_SUCCESS)
        throw UsageError(where + ": '" + topic + "' is not an MQTT topic" +
                         (pattern ? " pattern ('+' and '#' stand alone between '/', '#' last)"
                                  : " to publish on (no '+' or '#')"));
}

/// Writes one MQTT message to every inbound port whose pattern matches its topic (on the session's
/// thread: each inbound port has that one writer).
void deliver(std::vector<std::unique_ptr<Inbound>>& inbound, const mosquitto_message& message,
             PayloadMode mode, bool envelope) {
    const std::span<const std::uint8_t> payload(static_cast<const std::uint8_t*>(message.payload),
                                                static_cast<std::size_t>(message.payloadlen));
    for (auto& in : inbound) {
        bool matches = false;
        mosquitto_topic_matches_sub(in->pattern.c_str(), message.topic, &matches);
        if (!matches)
            continue;
        auto converted = payload_to_value(payload, mode);
        if (!converted.value) {
            in->counters.dropped(converted.reason, converted.detail + ", on topic " + message.topic);
            continue;
        }
        try {
            if (envelope)
                in->port.write(envelope_value(message.topic, std::move(*converted.value), message.retain));
            else
                in->port.write(*converted.value);
            in->counters.passed();
        } catch (const std::exception& error) {
            in->counters.dropped("not_delivered", error.what());
        }
    }
}

}  // namespace

int run_mqtt(const MqttOptions& options, const StopCheck& stop) {
    if (options.in.empty() && options.out.empty())
        throw UsageError("mqtt: nothing to bridge (give --in 'PATTERN=PORT' or --out 'PORT=TOPIC')");
    const auto broker = parse_broker(options.broker);
    const auto mode = *parse_payload_mode(options.payload);
    mosquitto_lib_init();  // the topic checks below need it; MqttSession's own call does nothing more

    std::vector<Mapping> in_mappings, out_mappings;
    std::vector<std::string> ports;
    for (const auto& text : options.in) {
        auto mapping = parse_mapping(text, "--in", false);
        require_topic(mapping.from, true, "--in '" + text + "'");
        require_port(mapping.to, "--in '" + text + "'");
        ports.push_back(mapping.to);
        in_mappings.push_back(std::move(mapping));
    }
    for (const auto& text : options.out) {
        auto mapping = parse_mapping(text, "--out", false);
        require_port(mapping.from, "--out '" + text + "'");
        require_topic(mapping.to, false, "--out '" + text + "'");
        ports.push_back(mapping.from);
        out_mappings.push_back(std::move(mapping));
    }
    require_distinct_ports(ports, "mqtt");

    MqttSettings settings;
    settings.host = broker.host;
    settings.port = broker.port;
    settings.client_id = options.id;
    settings.username = options.username;
    settings.password = options.password;
    if (!settings.password) {
        if (const char* env = std::getenv("MQTT_PASSWORD"))
            settings.password = env;
    }
    settings.cafile = options.cafile;
    settings.capath = options.capath;
    settings.cert = options.cert;
    settings.key = options.key;
    settings.insecure = options.insecure;
    settings.keepalive = options.keepalive;
    settings.qos = options.qos;
    settings.held_limit = options.held;
    for (const auto& mapping : in_mappings)
        settings.patterns.push_back(mapping.from);

    Client client;  // throws Error (refused) when no daemon runs
    std::vector<std::unique_ptr<Inbound>> inbound;
    for (const auto& mapping : in_mappings)
        inbound.push_back(std::make_unique<Inbound>(client, mapping.from, mapping.to));
    std::vector<std::unique_ptr<Outbound>> outbound;
    for (const auto& mapping : out_mappings) {
        // What this bridge injected from a pattern the out topic matches must not go back to it;
        // what came from other topics is a relay and goes out.
        std::set<std::string> loops;
        for (const auto& in : in_mappings) {
            bool matches = false;
            if (mosquitto_topic_matches_sub(in.from.c_str(), mapping.to.c_str(), &matches) ==
                    MOSQ_ERR_SUCCESS &&
                matches)
                loops.insert(in.to);
        }
        outbound.push_back(std::make_unique<Outbound>(client, mapping.from, "mqtt " + mapping.to, loops));
    }

    CounterReporter reporter;
    for (auto& in : inbound)
        reporter.add(in->port, in->counters);
    for (auto& out : outbound)
        reporter.add(out->port(), out->counters());
    reporter.start();

    MqttSession session(settings,
                        [&inbound, mode, envelope = options.envelope](const mosquitto_message& message) {
                            deliver(inbound, message, mode, envelope);
                        });
    session.start();
    for (std::size_t i = 0; i < outbound.size(); ++i) {
        outbound[i]->start([&session, mode, topic = out_mappings[i].to, retain = options.retain](
                               const Received& message, PortCounters& counters) {
            auto converted = value_to_payload(message.data, mode);
            if (!converted.value) {
                counters.dropped(converted.reason, converted.detail);
                return;
            }
            session.publish(topic, std::move(*converted.value), retain, counters);
        });
    }
    spdlog::info("bridging MQTT {} with {} in, {} out", options.broker, inbound.size(), outbound.size());

    while (!stop())
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    // The outbound threads publish through the session: they stop first.
    for (auto& out : outbound)
        out->stop();
    return 0;
}

}  // namespace plexus::bridge
