#include "plexus/proto/port_name.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/message.hpp"

namespace plexus::proto {
namespace {

std::string error_of(std::string_view name) {
    const auto error = port_name_error(name);
    EXPECT_TRUE(error) << name;
    return error.value_or("");
}

TEST(PortName_test, AcceptsValidNames) {
    for (const std::string_view name :
         {"/a", "/camera/out", "/face/out:1", "/robot-1/head.cam_left/raw", "/A/Z/0/9/_/-/./:"}) {
        EXPECT_FALSE(port_name_error(name)) << name << ": " << port_name_error(name).value_or("");
        EXPECT_TRUE(is_valid_port_name(name));
    }
}

TEST(PortName_test, RefusesEmptyName) {
    EXPECT_EQ(error_of(""), "port name is empty; it must start with '/', e.g. \"/camera/out\"");
}

TEST(PortName_test, RefusesNameWithoutLeadingSlash) {
    EXPECT_EQ(error_of("a/b"), "port name \"a/b\" must start with '/'");
}

TEST(PortName_test, RefusesSpaces) {
    EXPECT_EQ(error_of("/a b"), "port name \"/a b\" must not contain spaces (found ' ' at position 2)");
    EXPECT_EQ(error_of("/a\tb"),
              "port name \"/a\\x09b\" must not contain spaces (found '\\x09' at position 2)");
}

TEST(PortName_test, RefusesDoubleSlash) {
    EXPECT_EQ(error_of("/a//b"), "port name \"/a//b\" must not contain \"//\" (at position 2)");
}

TEST(PortName_test, RefusesTrailingSlash) {
    EXPECT_EQ(error_of("/a/"), "port name \"/a/\" must not end with '/'");
    EXPECT_EQ(error_of("/"), "port name \"/\" must not end with '/'");
}

TEST(PortName_test, RefusesNameLongerThan255Bytes) {
    const std::string longest = "/" + std::string(max_port_name - 1, 'x');
    EXPECT_FALSE(port_name_error(longest));
    const std::string too_long = longest + "x";
    const std::string error = error_of(too_long);
    EXPECT_NE(error.find("is 256 bytes, longer than the limit of 255"), std::string::npos) << error;
    EXPECT_NE(error.find("..."), std::string::npos) << "a huge name is shown cut short: " << error;
}

TEST(PortName_test, RefusesDisallowedCharacterNamingItsPosition) {
    EXPECT_EQ(error_of("/a#b"),
              "port name \"/a#b\" has character '#' at position 2; allowed are A-Z a-z 0-9 _ . / : -");
    EXPECT_EQ(error_of("/caf\xc3\xa9"),
              "port name \"/caf\\xc3\\xa9\" has character '\\xc3' at position 4; allowed are A-Z a-z 0-9 _ . "
              "/ : -");
    EXPECT_EQ(
        error_of(std::string_view("/a\0b", 4)),
        "port name \"/a\\x00b\" has character '\\x00' at position 2; allowed are A-Z a-z 0-9 _ . / : -");
}

}  // namespace
}  // namespace plexus::proto
