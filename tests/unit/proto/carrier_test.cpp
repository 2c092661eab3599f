#include "plexus/proto/carrier.hpp"

#include <gtest/gtest.h>

namespace plexus::proto {
namespace {

// The carriers that DESIGN.md shows.
const std::string_view design_examples[] = {
    "tcp",
    "udp",
    "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8",
    "tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec",
    "tcp+recv.priority+tc.0.5+st.1+bs.1+ex./face/out:-1",
};

bool same(const Carrier& a, const Carrier& b) {
    if (a.base != b.base || a.clauses.size() != b.clauses.size() || a.qos != b.qos) {
        return false;
    }
    for (std::size_t i = 0; i < a.clauses.size(); ++i) {
        const Clause& x = a.clauses[i];
        const Clause& y = b.clauses[i];
        if (x.side != y.side || x.modifier != y.modifier || x.params.size() != y.params.size()) {
            return false;
        }
        for (std::size_t j = 0; j < x.params.size(); ++j) {
            if (x.params[j].key != y.params[j].key || x.params[j].value != y.params[j].value) {
                return false;
            }
        }
    }
    return true;
}

Carrier parse(std::string_view text) {
    auto carrier = parse_carrier(text);
    EXPECT_TRUE(carrier) << text << ": " << (carrier ? "" : carrier.error().message);
    return carrier ? *carrier : Carrier{};
}

std::string parse_error(std::string_view text) {
    const auto carrier = parse_carrier(text);
    EXPECT_FALSE(carrier) << text;
    return carrier ? "" : carrier.error().message;
}

std::string validate_error(std::string_view text, const CarrierSupport& support = {}) {
    const Status status = validate_carrier(parse(text), support);
    EXPECT_FALSE(status) << text;
    return status ? "" : status.error().message;
}

TEST(Carrier_test, ParsesBareBase) {
    for (const std::string_view base : {"tcp", "udp", "mcast", "local"}) {
        const Carrier carrier = parse(base);
        EXPECT_EQ(carrier.base, base);
        EXPECT_TRUE(carrier.clauses.empty());
    }
}

TEST(Carrier_test, ParsesPortmonitorClauseWithOptions) {
    const Carrier carrier = parse("tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8");
    EXPECT_EQ(carrier.base, "tcp");
    ASSERT_EQ(carrier.clauses.size(), 1u);
    const Clause& clause = carrier.clauses[0];
    EXPECT_EQ(clause.side, Side::recv);
    EXPECT_EQ(clause.modifier, "portmonitor");
    ASSERT_EQ(clause.params.size(), 3u);
    EXPECT_EQ(clause.params[0].key, "type");
    EXPECT_EQ(clause.params[0].value, "lua");
    EXPECT_EQ(clause.params[1].key, "file");
    EXPECT_EQ(clause.params[1].value, "certainty");
    EXPECT_EQ(clause.params[2].key, "threshold");
    EXPECT_EQ(clause.params[2].value, "0.8");
}

TEST(Carrier_test, ParsesSendAndRecvClausesInOrder) {
    const Carrier carrier =
        parse("tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec");
    ASSERT_EQ(carrier.clauses.size(), 2u);
    EXPECT_EQ(carrier.clauses[0].side, Side::send);
    EXPECT_EQ(carrier.clauses[1].side, Side::recv);
    for (const Clause& clause : carrier.clauses) {
        EXPECT_EQ(clause.modifier, "portmonitor");
        ASSERT_EQ(clause.params.size(), 2u);
        ASSERT_NE(clause.find("file"), nullptr);
        EXPECT_EQ(clause.find("file")->value, "codec");
    }
}

TEST(Carrier_test, SplitsKeyValueAtFirstDotOnly) {
    const Carrier carrier = parse("tcp+recv.priority+tc.0.5+st.1+bs.1+ex./face/out:-1");
    ASSERT_EQ(carrier.clauses.size(), 1u);
    const Clause& clause = carrier.clauses[0];
    EXPECT_EQ(clause.modifier, "priority");
    EXPECT_EQ(clause.find("tc")->value, "0.5");
    EXPECT_EQ(clause.find("st")->value, "1");
    EXPECT_EQ(clause.find("bs")->value, "1");
    EXPECT_EQ(clause.find("ex")->value, "/face/out:-1");

    const Carrier file = parse("tcp+recv.portmonitor+file.a.b+ex./face/out:-1,/obj/out:0.5");
    EXPECT_EQ(file.clauses[0].find("file")->value, "a.b");
    EXPECT_EQ(file.clauses[0].find("ex")->value, "/face/out:-1,/obj/out:0.5");
}

TEST(Carrier_test, ParsesFlags) {
    const Carrier carrier = parse("tcp+recv.priority+aux+tc.2");
    const Clause& clause = carrier.clauses[0];
    const CarrierParam* aux = clause.find("aux");
    ASSERT_NE(aux, nullptr);
    EXPECT_FALSE(aux->value.has_value());
    EXPECT_EQ(clause.find("tc")->value, "2");
    EXPECT_EQ(clause.find("missing"), nullptr);
}

TEST(Carrier_test, ParsesChainOnOneSide) {
    const Carrier carrier = parse("tcp+recv.portmonitor+file.a+recv.portmonitor+file.b+recv.priority");
    ASSERT_EQ(carrier.clauses.size(), 3u);
    EXPECT_EQ(carrier.clauses[0].find("file")->value, "a");
    EXPECT_EQ(carrier.clauses[1].find("file")->value, "b");
    EXPECT_EQ(carrier.clauses[2].modifier, "priority");
    EXPECT_TRUE(carrier.clauses[2].params.empty());
}

TEST(Carrier_test, RefusesEmptyCarrier) {
    EXPECT_EQ(parse_error(""), "empty carrier");
}

TEST(Carrier_test, RefusesEmptyPartsNamingPosition) {
    EXPECT_EQ(parse_error("tcp++recv.x"), "empty part at position 4");
    EXPECT_EQ(parse_error("tcp+"), "empty part at position 4");
    EXPECT_EQ(parse_error("+tcp"), "empty part at position 0");
    EXPECT_EQ(parse_error("tcp+recv.portmonitor+"), "empty part at position 21");
}

TEST(Carrier_test, RefusesPartBeforeAnyClause) {
    EXPECT_EQ(parse_error("tcp+threshold.0.8"),
              "'threshold.0.8' at position 4 comes before any send./recv. clause");
    EXPECT_EQ(parse_error("tcp+aux+recv.priority"),
              "'aux' at position 4 comes before any send./recv. clause");
}

TEST(Carrier_test, RefusesClauseWithoutModifierName) {
    EXPECT_EQ(parse_error("tcp+recv."), "empty modifier name in 'recv.' at position 4");
    EXPECT_EQ(parse_error("tcp+send"), "'send' at position 4 needs a modifier name: 'send.NAME'");
}

TEST(Carrier_test, RefusesBaseThatIsAClause) {
    EXPECT_EQ(parse_error("recv.portmonitor+file.x"),
              "carrier must start with a base carrier, e.g. 'tcp+recv.portmonitor', not with the clause "
              "'recv.portmonitor'");
}

TEST(Carrier_test, RefusesEmptyKeyAndEmptyValue) {
    EXPECT_EQ(parse_error("tcp+recv.priority+.5"), "empty key in '.5' at position 18");
    EXPECT_EQ(parse_error("tcp+recv.portmonitor+file."),
              "missing value after 'file.' at position 21 (write 'file' alone for a flag)");
}

TEST(Carrier_test, ValuesMayHoldSpacesForConstraints) {
    const Carrier carrier = parse("tcp+recv.portmonitor+constraint.e_a and not (e_b or e_c)");
    EXPECT_EQ(carrier.clauses[0].find("constraint")->value, "e_a and not (e_b or e_c)");
    EXPECT_EQ(carrier.text(), "tcp+recv.portmonitor+constraint.e_a and not (e_b or e_c)");
}

TEST(Carrier_test, RefusesDuplicateKeyInClause) {
    EXPECT_EQ(parse_error("tcp+recv.priority+tc.1+tc.2"),
              "duplicate key 'tc' at position 23 in clause 'recv.priority'");
    // The same key in two clauses is fine.
    parse("tcp+send.portmonitor+file.a+recv.portmonitor+file.a");
}

TEST(Carrier_test, RefusesBadCharactersNamingPosition) {
    EXPECT_EQ(parse_error("tcp + recv.x"),
              "character '\\x20' at position 3 is not allowed in base carrier 'tcp ' (use A-Z a-z 0-9 _ -)");
    EXPECT_EQ(parse_error("tcp+recv.x\ty"), "character '\\x09' at position 10 is not allowed in a carrier");
    EXPECT_EQ(parse_error("tc/p"),
              "character '/' at position 2 is not allowed in base carrier 'tc/p' (use A-Z a-z 0-9 _ -)");
    EXPECT_EQ(
        parse_error("tcp+recv.port/monitor"),
        "character '/' at position 13 is not allowed in modifier name 'port/monitor' (use A-Z a-z 0-9 _ -)");
    EXPECT_EQ(parse_error("tcp+recv.x+ke:y.1"),
              "character ':' at position 13 is not allowed in key 'ke:y' (use A-Z a-z 0-9 _ -)");
}

TEST(Carrier_test, CanonicalTextParsesBackToEqualCarrier) {
    for (const std::string_view text : design_examples) {
        const Carrier carrier = parse(text);
        EXPECT_EQ(carrier.text(), text);
        EXPECT_TRUE(same(parse(carrier.text()), carrier)) << text;
    }
    const Carrier flags = parse("local+recv.priority+aux+ex./a:1,/b:-0.5+send.portmonitor+file.x.y");
    EXPECT_TRUE(same(parse(flags.text()), flags));
}

TEST(Carrier_test, TextOfBuiltCarrier) {
    Carrier carrier;
    carrier.base = "tcp";
    carrier.clauses.push_back({Side::send, "portmonitor", {{"file", "codec"}, {"aux", std::nullopt}}});
    carrier.clauses.push_back({Side::recv, "priority", {{"tc", "0.5"}}});
    EXPECT_EQ(carrier.text(), "tcp+send.portmonitor+file.codec+aux+recv.priority+tc.0.5");
    EXPECT_TRUE(same(parse(carrier.text()), carrier));
}

TEST(ValidateCarrier_test, AcceptsImplementedBases) {
    EXPECT_TRUE(validate_carrier(parse("tcp")));
    EXPECT_TRUE(validate_carrier(parse("local")));
}

TEST(ValidateCarrier_test, RefusesUnknownCarrier) {
    EXPECT_EQ(validate_error("foo"), "unknown carrier 'foo'");
    EXPECT_EQ(validate_error("foo+recv.portmonitor"), "unknown carrier 'foo'");
}

TEST(ValidateCarrier_test, RefusesUnimplementedBase) {
    CarrierSupport support;
    support.bases = {"tcp"};
    support.unimplemented_bases = {"mcast"};
    auto refused = validate_carrier(parse("mcast"), support);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().message, "carrier 'mcast' is not supported by this build");
}

TEST(ValidateCarrier_test, AcceptsEveryBaseOfTheContract) {
    for (const char* base : {"tcp", "udp", "mcast", "local"})
        EXPECT_TRUE(validate_carrier(parse(std::string(base) + "+recv.portmonitor+type.lua+file.x"))) << base;
}

TEST(ValidateCarrier_test, AcceptsPriority) {
    EXPECT_TRUE(validate_carrier(parse("tcp+recv.priority+tc.0.5+st.1+bs.1+ex./face/out:-1")));
}

TEST(ValidateCarrier_test, RefusesUnimplementedModifierNamingSide) {
    CarrierSupport support;
    support.unimplemented_modifiers = {"priority"};
    support.modifiers = {"portmonitor"};
    EXPECT_EQ(validate_error("tcp+send.portmonitor+type.lua+file.codec+send.priority", support),
              "modifier 'send.priority' is not supported by this build");
}

TEST(ValidateCarrier_test, AcceptsPortmonitorOnBothSides) {
    EXPECT_TRUE(
        validate_carrier(
            *parse_carrier("tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec"))
            .ok());
}

TEST(ValidateCarrier_test, RefusesUnknownModifier) {
    EXPECT_EQ(validate_error("tcp+recv.bogus"), "unknown modifier 'recv.bogus'");
    EXPECT_EQ(validate_error("local+send.bogus+x.1"), "unknown modifier 'send.bogus'");
}

TEST(ValidateCarrier_test, AcceptsModifiersTheBuildImplements) {
    CarrierSupport support;
    support.unimplemented_modifiers = {"priority"};
    support.modifiers = {"portmonitor"};
    EXPECT_TRUE(validate_carrier(parse("tcp+send.portmonitor+file.a+recv.portmonitor+file.b"), support));
    EXPECT_EQ(validate_error("tcp+recv.portmonitor+recv.priority", support),
              "modifier 'recv.priority' is not supported by this build");
}

TEST(CarrierQos_test, ReadsDscpAndPrioAnywhereAsTheConnections) {
    const Carrier before = parse("tcp+qos.dscp.46+qos.prio.7+recv.portmonitor+file.x");
    EXPECT_EQ(before.qos.dscp, 46);
    EXPECT_EQ(before.qos.prio, 7);
    ASSERT_EQ(before.clauses.size(), 1u);
    EXPECT_EQ(before.clauses[0].params.size(), 1u);  // qos is not handed to the script
    // After a clause, qos still belongs to the connection, not to the clause.
    const Carrier after = parse("tcp+recv.portmonitor+file.x+qos.prio.3+threshold.0.5+qos.dscp.0");
    EXPECT_EQ(after.qos.prio, 3);
    EXPECT_EQ(after.qos.dscp, 0);
    EXPECT_EQ(after.clauses[0].params.size(), 2u);
    EXPECT_EQ(after.text(), "tcp+qos.dscp.0+qos.prio.3+recv.portmonitor+file.x+threshold.0.5");
    EXPECT_TRUE(same(parse(after.text()), after));
    EXPECT_EQ(parse("udp+qos.prio.0").qos.prio, 0);
    EXPECT_FALSE(parse("udp").qos.dscp.has_value());
    EXPECT_EQ(parse("mcast+qos.dscp.63").text(), "mcast+qos.dscp.63");
}

TEST(CarrierQos_test, RefusesOutOfRangeAndMalformedValuesNamingThePart) {
    EXPECT_EQ(parse_error("tcp+qos.dscp.64"), "qos.dscp value '64' is out of range (0-63) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.prio.8"), "qos.prio value '8' is out of range (0-7) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.prio.-1"), "qos.prio value '-1' is out of range (0-7) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.dscp.99999999999999"),
              "qos.dscp value '99999999999999' is out of range (0-63) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.dscp.EF"),
              "qos.dscp value 'EF' is not a whole number (0-63) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.prio.1.5"),
              "qos.prio value '1.5' is not a whole number (0-7) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.prio. 1"),
              "qos.prio value ' 1' is not a whole number (0-7) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.dscp"),
              "'qos.dscp' needs a value: 'qos.dscp.N' with N 0-63 at position 4");
    EXPECT_EQ(
        parse_error("tcp+qos"),
        "unknown qos setting 'qos.' (use qos.dscp.N with N 0-63, or qos.prio.N with N 0-7) at position 4");
    EXPECT_EQ(parse_error("tcp+qos.tos.12"),
              "unknown qos setting 'qos.tos.12' (use qos.dscp.N with N 0-63, or qos.prio.N with N 0-7) at "
              "position 4");
    EXPECT_EQ(parse_error("tcp+qos.prio.1+recv.priority+qos.prio.2"), "duplicate 'qos.prio' at position 29");
}

TEST(CarrierQos_test, SocketPriorityPutsRealTimeClassesIntoPfifoFastsFirstBand) {
    // pfifo_fast's default priomap: priority -> band.
    constexpr int band_of[16] = {1, 2, 2, 2, 1, 2, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1};
    EXPECT_EQ(band_of[socket_priority_for_dscp(46)], 0);  // EF
    EXPECT_EQ(band_of[socket_priority_for_dscp(40)], 0);  // CS5
    EXPECT_EQ(band_of[socket_priority_for_dscp(48)], 0);  // CS6
    EXPECT_EQ(band_of[socket_priority_for_dscp(56)], 0);  // CS7
    EXPECT_EQ(band_of[socket_priority_for_dscp(0)], 1);   // default
    EXPECT_EQ(band_of[socket_priority_for_dscp(34)], 1);  // AF41
    EXPECT_EQ(band_of[socket_priority_for_dscp(8)], 2);   // CS1: lower effort
    for (int dscp = 0; dscp <= 63; ++dscp)
        EXPECT_LE(socket_priority_for_dscp(dscp), 6) << "7 would need CAP_NET_ADMIN";
}

}  // namespace
}  // namespace plexus::proto
