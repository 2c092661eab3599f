#include "mqtt_payload.hpp"

namespace plexus::bridge {

namespace {
bool holds_blob(const Value& value) {
    if (value.is_binary())
        return true;
    if (value.is_structured()) {
        for (const auto& item : value)
            if (holds_blob(item))
                return true;
    }
    return false;
}

std::vector<std::uint8_t> bytes_of(const std::string& text) {
    return {text.begin(), text.end()};
}
}  // namespace

std::optional<PayloadMode> parse_payload_mode(const std::string& text) {
    if (text == "json")
        return PayloadMode::json;
    if (text == "raw")
        return PayloadMode::raw;
    return std::nullopt;
}

bool is_utf8(std::span<const std::uint8_t> text) {
    std::size_t i = 0;
    while (i < text.size()) {
        const auto lead = text[i];
        std::size_t length = 0;
        std::uint32_t code = 0;
        if (lead < 0x80) {
            ++i;
            continue;
        } else if ((lead & 0xE0) == 0xC0) {
            length = 2;
            code = lead & 0x1F;
        } else if ((lead & 0xF0) == 0xE0) {
            length = 3;
            code = lead & 0x0F;
        } else if ((lead & 0xF8) == 0xF0) {
            length = 4;
            code = lead & 0x07;
        } else {
            return false;
        }
        if (i + length > text.size())
            return false;
        for (std::size_t k = 1; k < length; ++k) {
            if ((text[i + k] & 0xC0) != 0x80)
                return false;
            code = (code << 6) | (text[i + k] & 0x3F);
        }
        // The shortest form only, no UTF-16 surrogates, nothing beyond Unicode.
        static constexpr std::uint32_t smallest[] = {0, 0, 0x80, 0x800, 0x10000};
        if (code < smallest[length] || (code >= 0xD800 && code <= 0xDFFF) || code > 0x10FFFF)
            return false;
        i += length;
    }
    return true;
}

Converted<Value> payload_to_value(std::span<const std::uint8_t> payload, PayloadMode mode) {
    if (mode == PayloadMode::raw)
        return {Value::binary({payload.begin(), payload.end()}), {}, {}};
    // nlohmann's parser refuses invalid UTF-8 inside strings, so a value it returns is clean.
    auto parsed = Value::parse(payload.begin(), payload.end(), nullptr, false);
    if (!parsed.is_discarded())
        return {std::move(parsed), {}, {}};
    if (!is_utf8(payload))
        return {std::nullopt, "not_converted",
                "a payload of " + std::to_string(payload.size()) +
                    " bytes is neither JSON nor UTF-8 text (--payload raw passes bytes as blobs)"};
    return {Value(std::string(payload.begin(), payload.end())), {}, {}};
}

Converted<std::vector<std::uint8_t>> value_to_payload(const Value& value, PayloadMode mode) {
    if (value.is_binary())
        return {std::vector<std::uint8_t>(value.get_binary()), {}, {}};
    if (mode == PayloadMode::raw && value.is_string())
        return {bytes_of(value.get_ref<const std::string&>()), {}, {}};
    if (holds_blob(value))
        return {std::nullopt, "not_converted",
                "a value with a blob inside has no JSON text (write the blob alone to publish its bytes)"};
    try {
        return {bytes_of(value.dump()), {}, {}};
    } catch (const nlohmann::json::exception& error) {
        // dump() refuses strings that are not UTF-8.
        return {std::nullopt, "not_converted", std::string("no JSON text for the value: ") + error.what()};
    }
}

Value envelope_value(const std::string& topic, Value payload, bool retained) {
    return Value{{"topic", topic}, {"payload", std::move(payload)}, {"retained", retained}};
}

}  // namespace plexus::bridge
