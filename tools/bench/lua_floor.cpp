// plexus-lua-floor: what a port monitor costs per message inside plexusd, next to the least any
// Lua 5.4 monitor can cost under the DESIGN contract (msg.data of a map is a Lua table), measured
// in one process and one run. No sockets, no clients: the Lua side of `plexus-bench monitor` alone.
//
// The bare rows are lua_pcall of accept(msg) in a plain Lua state; msg.data builds the decoded map
// ({c = 0.9, pad = <44 bytes>}) as a table, the least a decoder can do under the contract, or, in
// the prototype row, as a userdata view. The plexusd rows are Monitor::process with the same
// scripts: sandbox, budget hook, msg object, envelope, counters.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <lua.hpp>

#include "monitor/monitor.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"

namespace {

using namespace plexus::daemon;
using Clock = std::chrono::steady_clock;

// PLEXUS_FLOOR_RUNS and PLEXUS_FLOOR_MESSAGES change them (fewer, for valgrind's instruction counts).
int messages_per_run = 300'000;
int runs = 7;
constexpr char pad[] = "xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx";  // 44 bytes: a 64 B map in all

/// One thing measured: a call per message, made `messages_per_run` times per run. Subjects are
/// measured run by run in turn (run 1 of every row, then run 2...), so that a stretch of noise on
/// the shared VM touches every row alike, and the ratios are taken run by run.
class Subject {
public:
    virtual ~Subject() = default;
    virtual void one_message() = 0;
    /// False when the monitor did not do what the row says (a field not seen, a message dropped).
    virtual bool right() const { return true; }
};

double ns_per_message(Subject& subject) {
    const auto start = Clock::now();
    for (int i = 0; i < messages_per_run; ++i)
        subject.one_message();
    return std::chrono::duration<double, std::nano>(Clock::now() - start).count() / messages_per_run;
}

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

/// msg.data as the contract has it: the decoded map, built as a table on each access.
int data_as_table(lua_State* L) {
    lua_createtable(L, 0, 2);
    lua_pushnumber(L, 0.9);
    lua_setfield(L, -2, "c");
    lua_pushlstring(L, pad, sizeof pad - 1);
    lua_setfield(L, -2, "pad");
    return 1;
}

// The alternative a contract change would allow: msg.data as a userdata holding a copy of the
// map's CBOR, decoding a field only when it is read. A prototype for this bench's map only (short
// text keys, float64 or text values), to measure what the change could gain; not product code.
std::vector<std::uint8_t> bench_map_cbor;
int view_metatable_key;

/// Pushes the value at `at` (a float64 or a short text) when `push`, and returns what follows it.
const std::uint8_t* next_value(lua_State* L, const std::uint8_t* at, bool push) {
    const std::uint8_t initial = *at++;
    if (initial == 0xfb) {  // float64
        std::uint64_t bits = 0;
        for (int i = 0; i < 8; ++i)
            bits = (bits << 8) | at[i];
        if (push)
            lua_pushnumber(L, std::bit_cast<double>(bits));
        return at + 8;
    }
    std::size_t length = initial & 0x1f;
    if (length == 24)
        length = *at++;
    if (push)
        lua_pushlstring(L, reinterpret_cast<const char*>(at), length);
    return at + length;
}

int view_index(lua_State* L) {
    const auto* at = static_cast<const std::uint8_t*>(lua_touserdata(L, 1));
    std::size_t key_size = 0;
    const char* key = lua_tolstring(L, 2, &key_size);
    const int pairs = *at++ & 0x1f;
    for (int i = 0; i < pairs; ++i) {
        const std::size_t size = *at++ & 0x1f;
        const bool match = key && size == key_size && std::memcmp(at, key, size) == 0;
        at = next_value(L, at + size, match);
        if (match)
            return 1;
    }
    lua_pushnil(L);
    return 1;
}

int data_as_view(lua_State* L) {
    void* copy = lua_newuserdatauv(L, bench_map_cbor.size(), 0);
    std::memcpy(copy, bench_map_cbor.data(), bench_map_cbor.size());
    lua_rawgetp(L, LUA_REGISTRYINDEX, &view_metatable_key);
    lua_setmetatable(L, -2);
    return 1;
}

/// A plain Lua state with `accept` at stack index 1 and a msg userdata at 2 whose `data` field
/// `data` pushes. With `hook`, the count hook of plexusd's time budget is set (it does nothing).
class BareSubject final : public Subject {
public:
    BareSubject(const char* accept_body, lua_CFunction data, bool hook) : L(luaL_newstate()) {
        luaL_openlibs(L);
        lua_gc(L, LUA_GCGEN, 0, 0);
        if (hook)
            lua_sethook(
                L, [](lua_State*, lua_Debug*) {}, LUA_MASKCOUNT, 1000);
        lua_createtable(L, 0, 1);
        lua_pushcfunction(L, view_index);
        lua_setfield(L, -2, "__index");
        lua_rawsetp(L, LUA_REGISTRYINDEX, &view_metatable_key);
        const std::string chunk = std::string("return function(msg) ") + accept_body + " end";
        if (luaL_dostring(L, chunk.c_str()) != LUA_OK) {
            std::fprintf(stderr, "%s\n", lua_tostring(L, -1));
            right_ = false;
            return;
        }
        lua_newuserdatauv(L, 8, 0);
        lua_createtable(L, 0, 1);
        lua_pushcfunction(L, data);
        lua_setfield(L, -2, "__index");
        lua_setmetatable(L, -2);
    }
    ~BareSubject() override { lua_close(L); }
    void one_message() override {
        lua_pushvalue(L, 1);
        lua_pushvalue(L, 2);
        right_ = lua_pcall(L, 1, 1, 0) == LUA_OK && lua_toboolean(L, -1) && right_;
        lua_pop(L, 1);
    }
    bool right() const override { return right_; }  // false: the script did not see its field

private:
    lua_State* L;
    bool right_ = true;
};

class NoHost : public monitor::MonitorHost {
public:
    plexus::proto::Status publish(monitor::Monitor&, const std::string&, const nlohmann::json&) override {
        return plexus::proto::Ok{};
    }
    void set_trig_interval(monitor::Monitor&, double) override {}
    double now() const override { return 0; }
    void monitor_gone(monitor::Monitor&) override {}
};

/// A 64 B map payload in a record, as it arrives at a monitor.
Message bench_message(const std::string& source, const char* key) {
    plexus::proto::Bytes payload;
    plexus::proto::encode_cbor(nlohmann::json{{key, 0.9}, {"pad", std::string(pad)}}, payload);
    plexus::proto::Bytes record;
    plexus::proto::append_record(record, source, 1, 1'700'000'000'000'000'000ull, payload);
    auto chunk = std::make_shared<Chunk>(record.size());
    std::memcpy(chunk->data(), record.data(), record.size());
    return Message{chunk, {chunk->data(), record.size()}, 1};
}

/// Monitor::process of `spec` on the bench message whose number is under `key`.
class PlexusdSubject final : public Subject {
public:
    PlexusdSubject(monitor::MonitorSpec spec, const char* key) {
        spec.source = "/bench/source";
        spec.destination = "/bench/sink";
        auto created = monitor::Monitor::create(spec, monitor::MonitorPolicy{}, host_);
        if (!created) {
            std::fprintf(stderr, "%s\n", created.error().message.c_str());
            passed_ = false;
            return;
        }
        monitor_ = std::move(*created);
        message_ = bench_message(spec.source, key);
    }
    void one_message() override {
        if (!monitor_)
            return;
        Message copy = message_;
        passed_ = monitor_->process(copy) == monitor::Monitor::Verdict::pass && passed_;
    }
    bool right() const override { return passed_; }  // false: not made, or it dropped a message

private:
    NoHost host_;
    std::unique_ptr<monitor::Monitor> monitor_;
    Message message_;
    bool passed_ = true;
};

std::unique_ptr<Subject> in_plexusd(const char* accept_body) {
    monitor::MonitorSpec spec;
    spec.script = monitor::Script{"floor", "floor.lua",
                                  std::string("PortMonitor.accept = function(msg) ") + accept_body + " end"};
    return std::make_unique<PlexusdSubject>(spec, "c");
}

/// The certainty example plugin with threshold 0.5 and no event: one field read, compared.
std::unique_ptr<Subject> compiled_one_field(const std::string& plugin_dir) {
    monitor::MonitorSpec spec;
    spec.type = monitor::MonitorType::plugin;
    spec.side = plexus::proto::Side::recv;
    spec.options = {{"threshold", "0.5"}};
    auto found = monitor::find_plugin("certainty", {plugin_dir});
    if (!found) {
        std::fprintf(stderr, "%s\n", found.error().message.c_str());
        std::exit(1);
    }
    spec.script = std::move(*found);
    return std::make_unique<PlexusdSubject>(spec, "certainty");
}

/// The loop alone: copying the message as the rows above do, no monitor.
class LoopSubject final : public Subject {
public:
    void one_message() override {
        Message copy = message_;
        bytes_ += copy.record.size();
    }
    bool right() const override { return bytes_ > 0; }

private:
    Message message_ = bench_message("/bench/source", "c");
    std::size_t bytes_ = 0;
};

struct Row {
    const char* name;
    std::function<std::unique_ptr<Subject>()> make;
};

}  // namespace

int main(int argc, char** argv) {
    spdlog::set_level(spdlog::level::warn);
    if (const char* value = std::getenv("PLEXUS_FLOOR_RUNS"))
        runs = std::max(1, std::atoi(value));
    if (const char* value = std::getenv("PLEXUS_FLOOR_MESSAGES"))
        messages_per_run = std::max(1, std::atoi(value));
    bench_map_cbor = nlohmann::json::to_cbor(nlohmann::json{{"c", 0.9}, {"pad", std::string(pad)}});
    constexpr const char* empty = "return true";
    constexpr const char* one_field = "return msg.data.c > 0.5";
    const std::string plugin_dir = PLEXUS_EXAMPLE_PLUGINS_DIR;
    const std::vector<Row> rows = {
        {"bare Lua, return true", [&] { return std::make_unique<BareSubject>(empty, data_as_table, false); }},
        {"bare Lua, msg.data.c > 0.5 (data as a table)",
         [&] { return std::make_unique<BareSubject>(one_field, data_as_table, false); }},
        {"  the same with the budget's count hook set",
         [&] { return std::make_unique<BareSubject>(one_field, data_as_table, true); }},
        {"  the same, data as a userdata view (prototype)",
         [&] { return std::make_unique<BareSubject>(one_field, data_as_view, true); }},
        {"plexusd Monitor::process, return true", [&] { return in_plexusd(empty); }},
        {"plexusd Monitor::process, msg.data.c > 0.5", [&] { return in_plexusd(one_field); }},
        {"the loop alone (a message copied, no monitor)", [&] { return std::make_unique<LoopSubject>(); }},
        {"plexusd Monitor::process, compiled (certainty.so)", [&] { return compiled_one_field(plugin_dir); }},
    };
    // `--row N`: that row alone (for a profiler or an instruction count).
    std::vector<std::size_t> chosen;
    if (argc == 3 && std::string(argv[1]) == "--row") {
        chosen.push_back(std::stoul(argv[2]));
        if (chosen.back() >= rows.size()) {
            std::fprintf(stderr, "--row takes 0 to %zu\n", rows.size() - 1);
            return 2;
        }
    } else {
        for (std::size_t i = 0; i < rows.size(); ++i)
            chosen.push_back(i);
    }
    std::vector<std::unique_ptr<Subject>> subjects;
    for (const auto i : chosen)
        subjects.push_back(rows[i].make());
    // Run by run, every row in turn.
    std::vector<std::vector<double>> times(subjects.size());
    for (int run = 0; run < runs; ++run) {
        for (std::size_t s = 0; s < subjects.size(); ++s)
            times[s].push_back(ns_per_message(*subjects[s]));
    }
    auto figure = [&](std::size_t s) { return subjects[s]->right() ? median(times[s]) : -1.0; };
    if (chosen.size() == 1) {
        std::printf("%s: %.1f ns\n", rows[chosen[0]].name, figure(0));
        return 0;
    }
    std::printf(
        "Lua side of a port monitor, 64 B map, ns per message (median of %d runs of %d, rows in turn)\n",
        runs, messages_per_run);
    for (std::size_t s = 0; s < subjects.size(); ++s)
        std::printf("  %-52s %10.1f\n", rows[s].name, figure(s));
    // The targets of issue 19: the Lua one-field call within 1.2x the bare one with the budget's
    // hook; the compiled one adds at most 30 ns to the loop. Taken run by run (the rows of one run
    // ran next to each other), then the median.
    std::vector<double> ratios;
    std::vector<double> added;
    for (int run = 0; run < runs; ++run) {
        ratios.push_back(times[5][run] / times[2][run]);
        added.push_back(times[7][run] - times[6][run]);
    }
    std::printf("  %-52s %10.2f\n", "ratio plexusd one-field / bare with hook", median(ratios));
    std::printf("  %-52s %10.1f\n", "compiled one-field added over the loop (ns)", median(added));
    return 0;
}
