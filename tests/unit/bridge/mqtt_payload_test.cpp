// MQTT payloads to Plexus values and back (tools/bridge/mqtt/mqtt_payload.hpp), in both modes.
#include <gtest/gtest.h>

#include "mqtt_payload.hpp"

namespace plexus::bridge {
namespace {

std::vector<std::uint8_t> bytes(const std::string& text) {
    return {text.begin(), text.end()};
}

TEST(MqttPayload_test, JsonTextBecomesItsValue) {
    const auto converted = payload_to_value(bytes(R"({"c":21.5,"ok":[true,null]})"), PayloadMode::json);
    ASSERT_TRUE(converted.value);
    EXPECT_EQ(*converted.value, Value::parse(R"({"c":21.5,"ok":[true,null]})"));
    EXPECT_EQ(*payload_to_value(bytes("42"), PayloadMode::json).value, Value(42));
    EXPECT_EQ(*payload_to_value(bytes("\"quoted\""), PayloadMode::json).value, Value("quoted"));
}

TEST(MqttPayload_test, OtherUtf8TextBecomesAString) {
    EXPECT_EQ(*payload_to_value(bytes("warm"), PayloadMode::json).value, Value("warm"));
    EXPECT_EQ(*payload_to_value(bytes("{broken"), PayloadMode::json).value, Value("{broken"));
    EXPECT_EQ(*payload_to_value(bytes("ünïcödé"), PayloadMode::json).value, Value("ünïcödé"));
    EXPECT_EQ(*payload_to_value(bytes(""), PayloadMode::json).value, Value(""));
}

TEST(MqttPayload_test, BytesThatAreNotUtf8AreNotConvertedInJsonMode) {
    for (const std::string bad :
         {std::string("\xff\xfe"), std::string("\"\xc3\x28\""), std::string("a\xe2\x82"),
          std::string("\xc0\xaf"), std::string("\xed\xa0\x80")}) {
        const auto converted = payload_to_value(bytes(bad), PayloadMode::json);
        EXPECT_FALSE(converted.value) << bad;
        EXPECT_EQ(converted.reason, "not_converted");
        EXPECT_FALSE(converted.detail.empty());
    }
}

TEST(MqttPayload_test, RawModeMakesABlobOfAnyBytes) {
    const std::vector<std::uint8_t> any{0xff, 0x00, '{', '}'};
    EXPECT_EQ(*payload_to_value(any, PayloadMode::raw).value, Value::binary(any));
    EXPECT_EQ(*payload_to_value(bytes("{}"), PayloadMode::raw).value, Value::binary(bytes("{}")));
}

TEST(MqttPayload_test, ValuesBecomeJsonTextInJsonMode) {
    EXPECT_EQ(*value_to_payload(Value{{"x", 1}}, PayloadMode::json).value, bytes(R"({"x":1})"));
    EXPECT_EQ(*value_to_payload(Value("parked"), PayloadMode::json).value, bytes("\"parked\""));
    EXPECT_EQ(*value_to_payload(Value(nullptr), PayloadMode::json).value, bytes("null"));
}

TEST(MqttPayload_test, ABlobIsItsBytesInBothModes) {
    const std::vector<std::uint8_t> image{1, 2, 0xff};
    EXPECT_EQ(*value_to_payload(Value::binary(image), PayloadMode::json).value, image);
    EXPECT_EQ(*value_to_payload(Value::binary(image), PayloadMode::raw).value, image);
}

TEST(MqttPayload_test, ABlobInsideAValueIsNotConvertedInJsonMode) {
    const auto converted = value_to_payload(Value{{"image", Value::binary({1, 2})}}, PayloadMode::json);
    EXPECT_FALSE(converted.value);
    EXPECT_EQ(converted.reason, "not_converted");
}

TEST(MqttPayload_test, AStringThatIsNotUtf8IsNotConvertedInJsonMode) {
    const auto converted = value_to_payload(Value(std::string("\xff")), PayloadMode::json);
    EXPECT_FALSE(converted.value);
    EXPECT_EQ(converted.reason, "not_converted");
}

TEST(MqttPayload_test, RawModeSendsAStringWithoutQuotesAndOtherValuesAsJson) {
    EXPECT_EQ(*value_to_payload(Value("text"), PayloadMode::raw).value, bytes("text"));
    EXPECT_EQ(*value_to_payload(Value{1, 2}, PayloadMode::raw).value, bytes("[1,2]"));
}

TEST(MqttPayload_test, EnvelopeNamesTopicPayloadAndRetained) {
    EXPECT_EQ(envelope_value("a/b", Value(1), true),
              Value::parse(R"({"topic":"a/b","payload":1,"retained":true})"));
}

TEST(MqttPayload_test, ModesParse) {
    EXPECT_EQ(parse_payload_mode("json"), PayloadMode::json);
    EXPECT_EQ(parse_payload_mode("raw"), PayloadMode::raw);
    EXPECT_FALSE(parse_payload_mode("JSON"));
}

}  // namespace
}  // namespace plexus::bridge
