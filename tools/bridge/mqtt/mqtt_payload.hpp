#pragma once
// MQTT payloads to Plexus values and back: pure functions, no I/O, so that what a bridge does with
// every kind of payload is tested without a broker (docs/BRIDGES-mqtt.md, "Payloads").
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <plexus/client.hpp>

namespace plexus::bridge {

/// How payloads are read and written: `json` (text, JSON when it parses) or `raw` (bytes as blobs).
enum class PayloadMode { json, raw };

/// Parses "json" or "raw"; nullopt for anything else.
std::optional<PayloadMode> parse_payload_mode(const std::string& text);

/// A conversion that may fail: `value` when it worked, else the counter `reason` and a `detail`
/// for the log.
template <typename T>
struct Converted {
    std::optional<T> value;
    std::string reason;
    std::string detail;
};

/// An MQTT payload as a Plexus value. json: JSON text becomes that value; other UTF-8 text
/// (including an empty payload) becomes a string; bytes that are not UTF-8 are "not_converted".
/// raw: always a blob of the bytes.
Converted<Value> payload_to_value(std::span<const std::uint8_t> payload, PayloadMode mode);

/// A Plexus value as an MQTT payload. A blob is its bytes in both modes. json: any other value is
/// its JSON text (a string with its quotes); a value holding a blob inside is "not_converted"
/// (JSON has no bytes). raw: a string is its text without quotes; any other value its JSON text.
Converted<std::vector<std::uint8_t>> value_to_payload(const Value& value, PayloadMode mode);

/// What an inbound port receives with --envelope: {"topic": T, "payload": V, "retained": B}.
Value envelope_value(const std::string& topic, Value payload, bool retained);

/// True if `text` is well-formed UTF-8 (no overlong forms, no surrogates, nothing above U+10FFFF).
bool is_utf8(std::span<const std::uint8_t> text);

}  // namespace plexus::bridge
