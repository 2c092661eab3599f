// Compiled monitors (type.so) in isolation: the certainty plugin against certainty.lua on the same
// inputs, refusals (wrong ABI version, no entry symbol, not a library, outside --monitor-libs),
// containment of a plugin that throws, the rest of the ABI through the `exercise` test plugin, and
// the value reader and builder against nlohmann's CBOR.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "arbitration/arbiter.hpp"
#include "monitor/monitor.hpp"
#include "monitor/plugin_values.hpp"
#include "monitor_fixture.hpp"
#include "plexus/proto/message.hpp"
#include "test_messages.hpp"

namespace plexus::daemon::monitor {
namespace {

using nlohmann::json;
namespace values = plugin_values;

const std::string test_plugins = PLEXUS_TEST_PLUGINS_DIR;
const std::string example_plugins = PLEXUS_EXAMPLE_PLUGINS_DIR;
const std::string monitor_scripts = PLEXUS_MONITORS_DIR;

/// A recv-side spec for plugin NAME in `directory`, or for NAME.lua from the shipped monitors.
proto::Result<MonitorSpec> spec_for(MonitorType type, const std::string& name, const std::string& directory,
                                    std::map<std::string, std::string> options = {}) {
    MonitorSpec spec;
    spec.type = type;
    spec.side = proto::Side::recv;
    spec.source = "/a";
    spec.destination = "/b";
    spec.carrier = "tcp+recv.portmonitor+type.so+file." + name;
    spec.options = std::move(options);
    auto found =
        type == MonitorType::plugin ? find_plugin(name, {directory}) : find_script(name, {directory});
    if (!found)
        return found.error();
    spec.script = std::move(*found);
    return spec;
}

struct Fixture : ::testing::Test {
    FakeHost host;
    arbitration::ManualClock clock;
    std::shared_ptr<arbitration::Arbiter> arbiter = std::make_shared<arbitration::Arbiter>(clock);

    proto::Result<std::unique_ptr<Monitor>> create(MonitorType type, const std::string& name,
                                                   const std::string& directory,
                                                   std::map<std::string, std::string> options = {},
                                                   std::shared_ptr<arbitration::Member> member = nullptr) {
        auto spec = spec_for(type, name, directory, std::move(options));
        if (!spec)
            return spec.error();
        spec->member = std::move(member);
        return Monitor::create(std::move(*spec), test_policy(), host);
    }
    std::string refusal(const std::string& name, const std::string& directory = test_plugins) {
        auto created = create(MonitorType::plugin, name, directory);
        EXPECT_FALSE(created.ok());
        return created.ok() ? std::string() : created.error().message;
    }
};

using PluginMonitor_test = Fixture;

TEST_F(PluginMonitor_test, CertaintyPluginBehavesLikeCertaintyLua) {
    const std::map<std::string, std::string> options{
        {"threshold", "0.7"}, {"event", "e_ok"}, {"lifetime", "0.5"}};
    auto lua_member = std::make_shared<arbitration::Member>(arbiter, "/lua");
    auto plugin_member = std::make_shared<arbitration::Member>(arbiter, "/plugin");
    auto lua = create(MonitorType::lua, "certainty", monitor_scripts, options, lua_member);
    auto plugin = create(MonitorType::plugin, "certainty", example_plugins, options, plugin_member);
    ASSERT_TRUE(lua.ok()) << lua.error().message;
    ASSERT_TRUE(plugin.ok()) << plugin.error().message;
    EXPECT_EQ(*(*lua)->getparam(), *(*plugin)->getparam());

    // Every kind of payload the script's type checks tell apart, and the threshold's edges.
    const std::vector<json> inputs{
        {{"certainty", 0.9}},
        {{"certainty", 0.7}},
        {{"certainty", 0.69}},
        {{"certainty", 1}},
        {{"certainty", 0}},
        {{"certainty", "0.9"}},
        {{"other", 0.9}},
        json::array({0.9}),
        0.9,
        "certainty",
        nullptr,
        {{"certainty", nullptr}},
        {{"certainty", -5}},
        {{"certainty", 1e300}},
        json::binary({1, 2}),
        {{"certainty", true}},
    };
    for (std::size_t i = 0; i < inputs.size(); ++i) {
        auto for_lua = make_message(inputs[i], i);
        auto for_plugin = make_message(inputs[i], i);
        EXPECT_EQ((*plugin)->process(for_plugin), (*lua)->process(for_lua)) << inputs[i].dump();
        EXPECT_EQ(payload_of(for_plugin), payload_of(for_lua)) << inputs[i].dump();
        // Each monitor's entries are its own: both must hold the event, or neither.
        std::lock_guard lock(arbiter->mutex());
        std::size_t lua_entries = 0;
        std::size_t plugin_entries = 0;
        for (const auto& entry : arbiter->events().entries(clock.now())) {
            lua_entries += entry.owner == (*lua)->id() ? 1 : 0;
            plugin_entries += entry.owner == (*plugin)->id() ? 1 : 0;
        }
        EXPECT_EQ(plugin_entries, lua_entries) << inputs[i].dump();
        clock.advance(0.2);  // lifetimes (0.5 s) run out between some of them
    }
    EXPECT_EQ((*plugin)->counters().dropped, (*lua)->counters().dropped);
    EXPECT_GT((*plugin)->counters().dropped, 0u);
    EXPECT_EQ((*plugin)->counters().errors, 0u);

    // setparam as `plexus param set` gives it (strings), then the same verdicts again.
    ASSERT_TRUE((*lua)->setparam({{"threshold", "0.95"}}).ok());
    ASSERT_TRUE((*plugin)->setparam({{"threshold", "0.95"}}).ok());
    EXPECT_EQ(*(*lua)->getparam(), *(*plugin)->getparam());
    auto a = make_message({{"certainty", 0.9}});
    auto b = make_message({{"certainty", 0.9}});
    EXPECT_EQ((*lua)->process(a), Monitor::Verdict::drop);
    EXPECT_EQ((*plugin)->process(b), Monitor::Verdict::drop);
}

TEST_F(PluginMonitor_test, CertaintyRefusesABadOptionWithTheScriptsWords) {
    auto lua = create(MonitorType::lua, "certainty", monitor_scripts, {{"threshold", "high"}});
    auto plugin = create(MonitorType::plugin, "certainty", example_plugins, {{"threshold", "high"}});
    ASSERT_FALSE(lua.ok());
    ASSERT_FALSE(plugin.ok());
    EXPECT_NE(plugin.error().message.find("refused the connection"), std::string::npos)
        << plugin.error().message;
    EXPECT_NE(plugin.error().message.find("threshold must be a number, got high"), std::string::npos)
        << plugin.error().message;
}

TEST_F(PluginMonitor_test, SendSideEventsFailLikeTheScriptsAndAreCounted) {
    auto spec = spec_for(MonitorType::plugin, "certainty", example_plugins, {{"event", "e"}});
    ASSERT_TRUE(spec.ok());
    spec->side = proto::Side::send;
    auto plugin = Monitor::create(std::move(*spec), test_policy(), host);
    ASSERT_TRUE(plugin.ok()) << plugin.error().message;
    auto message = make_message({{"certainty", 0.9}});
    EXPECT_EQ((*plugin)->process(message), Monitor::Verdict::drop);  // an accept error drops
    EXPECT_EQ((*plugin)->counters().errors, 1u);
    EXPECT_NE((*plugin)->last_error().find("setEvent: only recv-side monitors"), std::string::npos)
        << (*plugin)->last_error();
}

TEST_F(PluginMonitor_test, WrongAbiVersionIsRefusedNamingBothVersions) {
    const auto why = refusal("wrong_abi");
    EXPECT_NE(why.find("built for monitor ABI version 999"), std::string::npos) << why;
    EXPECT_NE(why.find("this plexusd speaks version 1"), std::string::npos) << why;
}

TEST_F(PluginMonitor_test, LibraryWithoutTheEntrySymbolIsRefused) {
    const auto why = refusal("no_entry");
    EXPECT_NE(why.find("has no plexus_monitor_entry symbol"), std::string::npos) << why;
}

TEST_F(PluginMonitor_test, FileThatIsNotALibraryIsRefusedWithTheLoadersReason) {
    char pattern[] = "/tmp/plexus-plugin-test-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    const std::string directory = pattern;
    std::ofstream(directory + "/text.so") << "this is not an ELF file\n";
    const auto why = refusal("text", directory);
    std::remove((directory + "/text.so").c_str());
    ::rmdir(directory.c_str());
    EXPECT_NE(why.find("failed to load"), std::string::npos) << why;
}

TEST_F(PluginMonitor_test, PluginsAreFoundOnlyInsideTheMonitorLibsDirectories) {
    auto elsewhere = find_plugin("certainty", {test_plugins});
    ASSERT_FALSE(elsewhere.ok());
    EXPECT_NE(elsewhere.error().message.find("not found in the --monitor-libs directories"),
              std::string::npos)
        << elsewhere.error().message;
    auto absolute = find_plugin(example_plugins + "/certainty", {test_plugins});
    ASSERT_FALSE(absolute.ok());
    EXPECT_NE(absolute.error().message.find("must be relative"), std::string::npos);
    auto climbing = find_plugin("../../examples/plugins/certainty", {test_plugins});
    ASSERT_FALSE(climbing.ok());
    EXPECT_NE(climbing.error().message.find("'..'"), std::string::npos);
    auto none = find_plugin("certainty", {});
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().message.find("no --monitor-libs directory"), std::string::npos);
    auto found = find_plugin("certainty.so", {test_plugins, example_plugins});
    ASSERT_TRUE(found.ok()) << found.error().message;
    EXPECT_EQ(found->path.front(), '/');
}

TEST_F(PluginMonitor_test, ThrowingPluginIsContainedCountedAndQuarantined) {
    auto plugin = create(MonitorType::plugin, "throwing", test_plugins);
    ASSERT_TRUE(plugin.ok()) << plugin.error().message;
    for (std::uint64_t seq = 1; seq <= 3; ++seq) {
        auto message = make_message({{"n", seq}}, seq);
        EXPECT_EQ((*plugin)->process(message), Monitor::Verdict::drop);
    }
    EXPECT_EQ((*plugin)->counters().errors, 3u);
    EXPECT_EQ((*plugin)->counters().dropped, 3u);
    EXPECT_NE((*plugin)->last_error().find("accept threw plugin exploded on message 3"), std::string::npos)
        << (*plugin)->last_error();
    EXPECT_TRUE((*plugin)->quarantined());
    EXPECT_EQ(host.gone, 1);
    auto after = make_message({{"n", 4}}, 4);
    EXPECT_EQ((*plugin)->process(after), Monitor::Verdict::drop);  // quarantined: by the accept policy
    EXPECT_EQ((*plugin)->stats()["type"], "so");
}

TEST_F(PluginMonitor_test, UpdateTrigPublishAndParamsWork) {
    auto plugin = create(MonitorType::plugin, "exercise", test_plugins, {{"port", "/ex/out"}});
    ASSERT_TRUE(plugin.ok()) << plugin.error().message;
    EXPECT_EQ(host.trig_interval, 0.5);

    auto rewritten = make_message({{"x", 21}}, 5);
    EXPECT_EQ((*plugin)->process(rewritten), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(rewritten), (json{{"x", 42.0}, {"seq", 5}, {"source", "/a"}}));
    auto untouched = make_message({{"y", 1}});
    EXPECT_EQ((*plugin)->process(untouched), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(untouched), (json{{"y", 1}}));
    auto dropped = make_message({{"drop", true}});
    EXPECT_EQ((*plugin)->process(dropped), Monitor::Verdict::drop);
    auto failing = make_message({{"fail", true}});
    EXPECT_EQ((*plugin)->process(failing), Monitor::Verdict::drop);
    EXPECT_EQ((*plugin)->last_error(), "accept: asked to fail");
    EXPECT_EQ((*plugin)->counters().rewritten, 1u);
    EXPECT_EQ((*plugin)->counters().errors, 1u);

    (*plugin)->trig();
    (*plugin)->trig();
    ASSERT_EQ(host.published.size(), 2u);
    EXPECT_EQ(host.published[1].first, "/ex/out");
    EXPECT_EQ(host.published[1].second, (json{{"trig", 2}}));

    EXPECT_EQ(*(*plugin)->getparam(), (json{{"count", 2}, {"factor", 2.0}}));
    ASSERT_TRUE((*plugin)->setparam({{"factor", 3}}).ok());
    auto tripled = make_message({{"x", 2}});
    (*plugin)->process(tripled);
    EXPECT_EQ(payload_of(tripled)["x"], 6.0);
}

// --- values ---

plexus_value view_of(const std::vector<std::uint8_t>& cbor) {
    return {cbor.data(), cbor.size()};
}

TEST(PluginValues_test, ReadsWhatNlohmannWrites) {
    const json value = {{"i", -3},      {"u", 1u << 20}, {"f", 0.25},
                        {"big", 1e300}, {"s", "text"},   {"b", json::binary({7})},
                        {"n", nullptr}, {"t", true},     {"a", {1, "two", {{"three", 3}}}}};
    const auto cbor = json::to_cbor(value);
    const plexus_value root = view_of(cbor);
    EXPECT_EQ(values::type(root), PLEXUS_TYPE_MAP);
    EXPECT_EQ(values::length(root), value.size());
    std::int64_t i = 0;
    double f = 0;
    EXPECT_EQ(values::get_int(values::map_get(root, "i"), &i), PLEXUS_MONITOR_OK);
    EXPECT_EQ(i, -3);
    EXPECT_EQ(values::get_number(values::map_get(root, "u"), &f), PLEXUS_MONITOR_OK);
    EXPECT_EQ(f, 1 << 20);
    EXPECT_EQ(values::get_number(values::map_get(root, "f"), &f), PLEXUS_MONITOR_OK);
    EXPECT_EQ(f, 0.25);
    EXPECT_EQ(values::get_number(values::map_get(root, "big"), &f), PLEXUS_MONITOR_OK);
    EXPECT_EQ(f, 1e300);
    const char* text = nullptr;
    std::size_t size = 0;
    EXPECT_EQ(values::get_string(values::map_get(root, "s"), &text, &size), PLEXUS_MONITOR_OK);
    EXPECT_EQ(std::string(text, size), "text");
    EXPECT_EQ(values::type(values::map_get(root, "b")), PLEXUS_TYPE_BYTES);
    EXPECT_EQ(values::type(values::map_get(root, "n")), PLEXUS_TYPE_NULL);
    EXPECT_EQ(values::type(values::map_get(root, "missing")), PLEXUS_TYPE_ABSENT);
    const plexus_value array = values::map_get(root, "a");
    EXPECT_EQ(values::length(array), 3u);
    EXPECT_EQ(values::get_int(values::map_get(values::array_at(array, 2), "three"), &i), PLEXUS_MONITOR_OK);
    EXPECT_EQ(i, 3);
    EXPECT_EQ(values::type(values::array_at(array, 3)), PLEXUS_TYPE_ABSENT);
    EXPECT_EQ(values::get_int(values::map_get(root, "s"), &i), PLEXUS_MONITOR_ERROR);  // wrong type
}

TEST(PluginValues_test, EveryTruncationReadsAsInvalidOrAbsentNeverPastTheEnd) {
    const auto cbor = json::to_cbor(json{{"certainty", 0.5}, {"list", {1, 2, {{"k", "v"}}}}});
    for (std::size_t cut = 0; cut < cbor.size(); ++cut) {
        // A copy of exactly `cut` bytes: AddressSanitizer sees any read past it.
        const std::vector<std::uint8_t> part(cbor.begin(), cbor.begin() + static_cast<long>(cut));
        const plexus_value view{part.empty() ? nullptr : part.data(), part.size()};
        double number = 0;
        values::get_number(values::map_get(view, "certainty"), &number);
        values::length(values::map_get(view, "list"));
        EXPECT_EQ(values::first_item(view).bytes, nullptr) << cut;
    }
}

TEST(PluginValues_test, MapGetFindsEveryKindOfValueBehindEveryKindOfKey) {
    // map_get steps over short text keys and simple values itself and hands the rest to the
    // general walk: each lookup must give exactly the value's bytes, whatever came before it.
    const std::string long_key(40, 'k');
    json value = {{"a", 1},
                  {"ab", 300},
                  {"abc", 70000},
                  {"abcd", 5000000000ull},
                  {"neg", -20000},
                  {"f", 0.1},
                  {"t", false},
                  {"n", nullptr},
                  {"short", "hi"},
                  {"long", std::string(30, 'x')},
                  {"bytes", json::binary({1, 2, 3})},
                  {"nested", {{"deep", {1, {{"x", 2}}}}}},
                  {long_key, "after a long key"},
                  {"last", 42}};
    auto cbor = json::to_cbor(value);
    for (const auto& [key, expected] : value.items()) {
        const plexus_value found = values::map_get(view_of(cbor), key.c_str());
        ASSERT_NE(found.bytes, nullptr) << key;
        EXPECT_EQ(json::from_cbor(std::vector<std::uint8_t>(found.bytes, found.bytes + found.size)), expected)
            << key;
    }
    EXPECT_EQ(values::map_get(view_of(cbor), "lon").bytes, nullptr);  // a prefix of a key
    EXPECT_EQ(values::map_get(view_of(cbor), "lastly").bytes, nullptr);
    // Half and single floats, which nlohmann does not write: written here by hand.
    const std::vector<std::uint8_t> floats{0xa2, 0x61, 'h',  0xf9, 0x3c, 0x00,         // "h": 1.0 (f16)
                                           0x61, 's',  0xfa, 0x3f, 0xc0, 0x00, 0x00};  // "s": 1.5 (f32)
    double number = 0;
    EXPECT_EQ(values::get_number(values::map_get(view_of(floats), "s"), &number), PLEXUS_MONITOR_OK);
    EXPECT_EQ(number, 1.5);
    EXPECT_EQ(values::get_number(values::map_get(view_of(floats), "h"), &number), PLEXUS_MONITOR_OK);
    EXPECT_EQ(number, 1.0);
    // A map with a non-text key before the one looked for.
    const std::vector<std::uint8_t> mixed{0xa2, 0x01, 0x02, 0x61, 'k', 0x03};  // {1: 2, "k": 3}
    std::int64_t whole = 0;
    EXPECT_EQ(values::get_int(values::map_get(view_of(mixed), "k"), &whole), PLEXUS_MONITOR_OK);
    EXPECT_EQ(whole, 3);
    // Cut anywhere, nothing is read past the end (AddressSanitizer watches the exact copy).
    for (std::size_t cut = 0; cut < cbor.size(); ++cut) {
        const std::vector<std::uint8_t> part(cbor.begin(), cbor.begin() + static_cast<long>(cut));
        const plexus_value view{part.empty() ? nullptr : part.data(), part.size()};
        // nlohmann writes keys in order: "t" comes last, and its value is never whole before the end.
        EXPECT_EQ(values::map_get(view, "t").bytes, nullptr) << cut;
        values::get_number(values::map_get(view, "f"), &number);
    }
}

TEST(PluginValues_test, BuilderWritesWhatNlohmannReadsAndRefusesMisuse) {
    plexus_builder builder;
    values::begin_map(&builder, 2);
    values::put_string(&builder, "list", 4);
    values::begin_array(&builder, 3);
    values::put_int(&builder, -7);
    values::put_null(&builder);
    values::begin_array(&builder, 0);
    values::put_string(&builder, "x", 1);
    values::put_float(&builder, 1.5);
    const plexus_value built = values::value_of(&builder);
    ASSERT_NE(built.bytes, nullptr) << values::problem_of(builder);
    EXPECT_EQ(json::from_cbor(built.bytes, built.bytes + built.size),
              (json{{"list", {-7, nullptr, json::array()}}, {"x", 1.5}}));

    values::put_int(&builder, 1);  // a second top-level value
    EXPECT_EQ(values::value_of(&builder).bytes, nullptr);
    EXPECT_NE(values::problem_of(builder).find("after the top-level value"), std::string::npos);

    values::reset(&builder);
    values::begin_array(&builder, 2);
    values::put_bool(&builder, 1);
    EXPECT_EQ(values::value_of(&builder).bytes, nullptr);
    EXPECT_EQ(values::problem_of(builder), "an array or map is missing 1 item(s)");
}

}  // namespace
}  // namespace plexus::daemon::monitor
