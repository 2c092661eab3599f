// The deployment CA (`plexus pki`, tools/cli/pki.cpp) and what reads its identities
// (proto/identity.hpp), in-process on files: what is made, with which modes, and each refusal.
#include "pki.hpp"

#include <sys/stat.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "plexus/proto/identity.hpp"

namespace plexus::cli {
namespace {

namespace fs = std::filesystem;

class Pki_test : public ::testing::Test {
protected:
    void SetUp() override {
        char pattern[] = "/tmp/plexus-pki-XXXXXX";
        ASSERT_NE(::mkdtemp(pattern), nullptr);
        dir = pattern;
        ASSERT_TRUE(pki_init(ca(), 30).ok());
    }
    void TearDown() override { fs::remove_all(dir); }
    std::string ca() const { return dir + "/ca"; }
    static unsigned mode(const std::string& path) {
        struct stat status {};
        ::stat(path.c_str(), &status);
        return status.st_mode & 0777;
    }
    std::string dir;
    const proto::Subject arm{proto::Subject::Kind::node, "arm"};
};

TEST_F(Pki_test, AnIssuedIdentityLoadsAndNamesItsNode) {
    EXPECT_EQ(mode(ca() + "/ca.key"), 0600u);
    EXPECT_EQ(mode(ca()), 0700u);
    const auto issued = pki_issue(ca(), arm, "", 30);
    ASSERT_TRUE(issued.ok()) << issued.error().message;
    EXPECT_EQ(*issued, ca() + "/nodes/arm");
    EXPECT_EQ(mode(*issued + "/node.key"), 0600u);
    const auto identity = proto::Identity::load(*issued);
    ASSERT_TRUE(identity.ok()) << identity.error().message;
    EXPECT_EQ(identity->subject(), arm);
    EXPECT_NE(identity->crl_changed(), 0);

    const proto::Subject names{proto::Subject::Kind::names, "names0"};
    const auto server = pki_issue(ca(), names, dir + "/elsewhere", 30);
    ASSERT_TRUE(server.ok());
    EXPECT_EQ(proto::Identity::load(*server)->subject(), names);
    EXPECT_EQ(names.uri(), "plexus:names:names0");
    EXPECT_EQ(proto::Subject::from_uri("plexus:node:arm"), arm);
    EXPECT_FALSE(proto::Subject::from_uri("plexus:node:"));
    EXPECT_FALSE(proto::Subject::from_uri("https://arm"));
}

TEST_F(Pki_test, ANodeHoldsOneCertificateUntilItIsRevoked) {
    ASSERT_TRUE(pki_issue(ca(), arm, "", 30).ok());
    const auto again = pki_issue(ca(), arm, dir + "/second", 30);
    ASSERT_FALSE(again.ok());
    EXPECT_NE(again.error().message.find("revoke it first"), std::string::npos) << again.error().message;
    const auto before = proto::Identity::load(ca() + "/nodes/arm")->crl_changed();
    const auto revoked = pki_revoke(ca(), arm);
    ASSERT_TRUE(revoked.ok()) << revoked.error().message;
    EXPECT_EQ(*revoked, 2u);  // the CA's own is 1
    // The new list is in the CA and in the identity under it.
    EXPECT_NE(proto::Identity::load(ca() + "/nodes/arm")->crl_changed(), before);
    EXPECT_FALSE(pki_revoke(ca(), arm).ok());  // nothing left to revoke
    EXPECT_TRUE(pki_issue(ca(), arm, dir + "/second", 30).ok());
    // The list says which is which.
    const auto listed = pki_list(ca());
    ASSERT_TRUE(listed.ok());
    ASSERT_EQ(listed->size(), 2u) << listed->dump();
    EXPECT_EQ((*listed)[0]["subject"], "plexus:node:arm");
    EXPECT_EQ((*listed)[0]["revoked"], true);
    EXPECT_EQ((*listed)[1]["revoked"], false);
    EXPECT_EQ((*listed)[1]["serial"], 3);
    EXPECT_FALSE(pki_list(dir + "/no-ca").ok());
}

TEST_F(Pki_test, AnIdentityThatCannotBeTrustedIsRefusedSayingWhichFile) {
    const auto issued = *pki_issue(ca(), arm, "", 30);
    ::chmod((issued + "/node.key").c_str(), 0644);
    auto loaded = proto::Identity::load(issued);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find("node.key may be read by others"), std::string::npos);
    ::chmod((issued + "/node.key").c_str(), 0600);

    // A certificate of another CA beside this CA's certificate.
    ASSERT_TRUE(pki_init(dir + "/other", 30).ok());
    const auto foreign = *pki_issue(dir + "/other", arm, "", 30);
    fs::copy_file(ca() + "/ca.crt", foreign + "/ca.crt", fs::copy_options::overwrite_existing);
    loaded = proto::Identity::load(foreign);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find("not issued by the CA of ca.crt"), std::string::npos)
        << loaded.error().message;

    // Another node's key beside this certificate.
    const auto other = *pki_issue(ca(), {proto::Subject::Kind::node, "other"}, "", 30);
    fs::copy_file(other + "/node.key", issued + "/node.key", fs::copy_options::overwrite_existing);
    loaded = proto::Identity::load(issued);
    ASSERT_FALSE(loaded.ok());
    EXPECT_NE(loaded.error().message.find("not the key of node.crt"), std::string::npos);

    EXPECT_FALSE(proto::Identity::load(dir + "/nowhere").ok());
    EXPECT_FALSE(pki_init(ca(), 30).ok());  // a CA is there already
    EXPECT_FALSE(pki_issue(ca(), {proto::Subject::Kind::node, "../escape"}, "", 30).ok());
    EXPECT_FALSE(pki_issue(dir + "/no-ca", arm, "", 30).ok());
}

TEST_F(Pki_test, WebHostsGoIntoTheCertificateAsAddressesOrNames) {
    EXPECT_TRUE(pki_issue(ca(), arm, "", 30, {"10.0.0.11", "robot.local", "fe80::1"}).ok());
    const auto refused = pki_issue(ca(), {proto::Subject::Kind::node, "b"}, "", 30, {"a,b"});
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("--web 'a,b'"), std::string::npos);
}

}  // namespace
}  // namespace plexus::cli
