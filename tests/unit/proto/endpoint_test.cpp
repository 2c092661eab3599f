#include "plexus/proto/endpoint.hpp"

#include <gtest/gtest.h>

namespace plexus::proto {
namespace {

std::string error_of(std::string_view text) {
    const auto endpoint = parse_endpoint(text);
    EXPECT_FALSE(endpoint) << text;
    return endpoint ? "" : endpoint.error().message;
}

TEST(Endpoint_test, ParsesHostAndPort) {
    const auto endpoint = parse_endpoint("127.0.0.1:10100");
    ASSERT_TRUE(endpoint) << endpoint.error().message;
    EXPECT_EQ(endpoint->host, "127.0.0.1");
    EXPECT_EQ(endpoint->port, 10100);
    EXPECT_EQ(endpoint->text(), "127.0.0.1:10100");
}

TEST(Endpoint_test, AcceptsPortZeroAndMax) {
    const auto any = parse_endpoint("localhost:0");
    ASSERT_TRUE(any);
    EXPECT_EQ(any->host, "localhost");
    EXPECT_EQ(any->port, 0);
    const auto max = parse_endpoint("host.example:65535");
    ASSERT_TRUE(max);
    EXPECT_EQ(max->port, 65535);
}

TEST(Endpoint_test, ParsesBracketedIpv6) {
    const auto endpoint = parse_endpoint("[::1]:5000");
    ASSERT_TRUE(endpoint) << endpoint.error().message;
    EXPECT_EQ(endpoint->host, "::1");
    EXPECT_EQ(endpoint->port, 5000);
    EXPECT_EQ(endpoint->text(), "[::1]:5000");
    const auto again = parse_endpoint(endpoint->text());
    ASSERT_TRUE(again);
    EXPECT_EQ(again->host, "::1");
}

TEST(Endpoint_test, RefusesMissingPort) {
    EXPECT_EQ(error_of("localhost"), "missing port in 'localhost'; expected HOST:PORT, e.g. 127.0.0.1:10100");
    EXPECT_EQ(error_of("localhost:"),
              "missing port in 'localhost:'; expected HOST:PORT, e.g. 127.0.0.1:10100");
    EXPECT_EQ(error_of("[::1]"), "missing port in '[::1]'; expected [HOST]:PORT, e.g. [::1]:5000");
}

TEST(Endpoint_test, RefusesNonNumericPort) {
    EXPECT_EQ(error_of("localhost:http"), "port 'http' in 'localhost:http' is not a number");
    EXPECT_EQ(error_of("localhost:-1"), "port '-1' in 'localhost:-1' is not a number");
    EXPECT_EQ(error_of("localhost:+80"), "port '+80' in 'localhost:+80' is not a number");
}

TEST(Endpoint_test, RefusesPortOutOfRange) {
    EXPECT_EQ(error_of("localhost:65536"), "port '65536' in 'localhost:65536' is out of range (0-65535)");
    EXPECT_EQ(error_of("h:99999999999999999999999"),
              "port '99999999999999999999999' in 'h:99999999999999999999999' is out of range (0-65535)");
}

TEST(Endpoint_test, RefusesMissingHost) {
    EXPECT_EQ(error_of(":80"), "missing host in ':80'; expected HOST:PORT, e.g. 127.0.0.1:10100");
    EXPECT_EQ(error_of("[]:80"), "missing host in '[]:80'; expected HOST:PORT, e.g. 127.0.0.1:10100");
}

TEST(Endpoint_test, RefusesMalformedAddresses) {
    EXPECT_EQ(error_of(""), "empty address; expected HOST:PORT, e.g. 127.0.0.1:10100");
    EXPECT_EQ(error_of("::1:5000"),
              "address '::1:5000' is ambiguous: write an IPv6 address in brackets, e.g. [::1]:5000");
    EXPECT_EQ(error_of("[::1:5000"), "address '[::1:5000' has '[' without ']'");
    EXPECT_EQ(error_of("[::1]5000"), "address '[::1]5000' must have ':' right after ']'");
    EXPECT_EQ(error_of("a]:80"), "address 'a]:80' has a stray bracket");
    EXPECT_EQ(error_of("local host:80"), "address 'local host:80' contains a space or control character");
}

}  // namespace
}  // namespace plexus::proto
