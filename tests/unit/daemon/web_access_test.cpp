// Who the web endpoint answers (web/access.hpp), the query strings it reads, and the token.
#include <gtest/gtest.h>

#include "web/access.hpp"

namespace plexus::daemon::web {
namespace {

namespace ip = boost::asio::ip;

proto::Secret secret() {
    return *proto::Secret::from_bytes("a deployment secret of 32 bytes!");
}

TEST(WebAccess_test, FindsTheTokenInTheAuthorizationHeaderOrTheCookie) {
    EXPECT_EQ(token_of("Bearer abc", ""), "abc");
    EXPECT_EQ(token_of("  Bearer  abc ", ""), "abc");
    EXPECT_EQ(token_of("", "theme=dark; plexus_token=xyz; other=1"), "xyz");
    EXPECT_EQ(token_of("", "plexus_token=xyz"), "xyz");
    EXPECT_EQ(token_of("Basic dXNlcg==", "plexus_tokenx=1"), std::nullopt);
    EXPECT_EQ(token_of("", ""), std::nullopt);
}

TEST(WebAccess_test, ReadsQueryValuesPercentDecoded) {
    EXPECT_EQ(query_value("port=%2Fgaze%2Fin&check=true", "port"), "/gaze/in");
    EXPECT_EQ(query_value("port=%2Fgaze%2Fin&check=true", "check"), "true");
    EXPECT_EQ(query_value("port=/a+b", "port"), "/a+b");    // '+' is a legal character of names
    EXPECT_EQ(query_value("port=%zz%2", "port"), "%zz%2");  // stray '%' left as it is
    EXPECT_EQ(query_value("portx=1", "port"), "");
    EXPECT_EQ(query_value("", "port"), "");
    EXPECT_EQ(query_value("port", "port"), "");
}

TEST(WebAccess_test, TheTokenIsDerivedFromTheSecretAndIsNotTheSecret) {
    const auto token = secret().web_token();
    EXPECT_EQ(token.size(), 64u);
    EXPECT_EQ(token, secret().web_token());
    EXPECT_EQ(token.find("deployment"), std::string::npos);
    EXPECT_NE(token, proto::Secret::from_bytes("another secret, also of 32 bytes")->web_token());
}

TEST(WebAccess_test, LoopbackIsAnsweredAndBeyondItOnlyWithTheToken) {
    const Access access(secret(), false);
    const auto token = secret().web_token();
    const auto loopback = ip::make_address("127.0.0.1");
    const auto mapped = ip::make_address("::ffff:127.0.0.1");
    const auto beyond = ip::make_address("10.1.2.3");
    EXPECT_EQ(access.check(loopback, "127.0.0.1:8080", "", ""), Refusal::none);
    EXPECT_EQ(access.check(mapped, "[::1]:8080", "", ""), Refusal::none);
    EXPECT_EQ(access.check(loopback, "localhost:8080", "", ""), Refusal::none);
    EXPECT_EQ(access.check(beyond, "10.1.2.1:8080", "", ""), Refusal::token);
    EXPECT_EQ(access.check(beyond, "10.1.2.1:8080", "Bearer wrong", ""), Refusal::token);
    EXPECT_EQ(access.check(beyond, "robot.local:8080", "Bearer " + token, ""), Refusal::none);
    EXPECT_EQ(access.check(beyond, "10.1.2.1:8080", "", "plexus_token=" + token), Refusal::none);
    EXPECT_TRUE(access.token_ok(token));
    EXPECT_FALSE(access.token_ok(token.substr(1)));
}

TEST(WebAccess_test, ATokenlessRequestMustNameAnAddressSoThatDnsRebindingFindsNothing) {
    const Access access(secret(), false);
    const auto loopback = ip::make_address("127.0.0.1");
    EXPECT_EQ(access.check(loopback, "evil.example", "", ""), Refusal::host);
    EXPECT_EQ(access.check(loopback, "evil.example:8080", "", ""), Refusal::host);
    EXPECT_EQ(access.check(loopback, "evil.example", "Bearer " + secret().web_token(), ""), Refusal::none);
}

TEST(WebAccess_test, InsecureWithoutASecretAnswersEveryone) {
    const Access open(std::nullopt, true);
    EXPECT_EQ(open.check(ip::make_address("10.1.2.3"), "robot.local", "", ""), Refusal::none);
    const Access closed(std::nullopt, false);
    EXPECT_EQ(closed.check(ip::make_address("10.1.2.3"), "10.0.0.1", "", ""), Refusal::token);
    EXPECT_FALSE(closed.token_ok(""));
}

}  // namespace
}  // namespace plexus::daemon::web
