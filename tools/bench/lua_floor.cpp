// plexus-lua-floor: what a port monitor costs per message inside plexusd, next to the least any
// Lua 5.4 monitor can cost under the DESIGN contract (msg.data of a map is a Lua table), measured
// in one process and one run. No sockets, no clients: the Lua side of `plexus-bench monitor` alone.
//
//   bare_empty_accept   lua_pcall of accept(msg) that returns true: a plain Lua state, no hook
//   bare_one_field      the same, reading msg.data.c, where msg.data builds the decoded map as a
//                       table ({c = 0.9, pad = <44 bytes>}): the least a decoder can do
//   plexusd_empty_accept    Monitor::process with the same script: sandbox, budget hook, msg object
//   plexusd_one_field       Monitor::process with the one-field accept of `plexus-bench monitor`
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
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

constexpr int messages_per_run = 300'000;
constexpr int runs = 7;
constexpr char pad[] = "xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx";  // 44 bytes: a 64 B map in all

double median_ns_per_message(const std::function<void()>& one_message) {
    std::vector<double> results;
    for (int run = 0; run < runs; ++run) {
        const auto start = Clock::now();
        for (int i = 0; i < messages_per_run; ++i)
            one_message();
        results.push_back(std::chrono::duration<double, std::nano>(Clock::now() - start).count() /
                          messages_per_run);
    }
    std::sort(results.begin(), results.end());
    return results[results.size() / 2];
}

/// A plain Lua state with `accept` at stack index 1 and a msg userdata at 2 whose `data` field is
/// built as a table on each access, as the contract requires of any implementation.
double bare(const char* accept_body) {
    lua_State* L = luaL_newstate();
    luaL_openlibs(L);
    lua_gc(L, LUA_GCGEN, 0, 0);
    const std::string chunk = std::string("return function(msg) ") + accept_body + " end";
    if (luaL_dostring(L, chunk.c_str()) != LUA_OK) {
        std::fprintf(stderr, "%s\n", lua_tostring(L, -1));
        return -1;
    }
    lua_newuserdatauv(L, 8, 0);
    lua_createtable(L, 0, 1);
    lua_pushcfunction(L, [](lua_State* L) {
        lua_createtable(L, 0, 2);
        lua_pushnumber(L, 0.9);
        lua_setfield(L, -2, "c");
        lua_pushlstring(L, pad, sizeof pad - 1);
        lua_setfield(L, -2, "pad");
        return 1;
    });
    lua_setfield(L, -2, "__index");
    lua_setmetatable(L, -2);
    const double ns = median_ns_per_message([L] {
        lua_pushvalue(L, 1);
        lua_pushvalue(L, 2);
        lua_pcall(L, 1, 1, 0);
        lua_pop(L, 1);
    });
    lua_close(L);
    return ns;
}

class NoHost : public monitor::MonitorHost {
public:
    plexus::proto::Status publish(monitor::Monitor&, const std::string&, const nlohmann::json&) override {
        return plexus::proto::Ok{};
    }
    void set_trig_interval(monitor::Monitor&, double) override {}
    double now() const override { return 0; }
    void monitor_gone(monitor::Monitor&) override {}
};

double in_plexusd(const char* accept_body) {
    NoHost host;
    monitor::MonitorSpec spec;
    spec.script = monitor::Script{"floor", "floor.lua",
                                  std::string("PortMonitor.accept = function(msg) ") + accept_body + " end"};
    spec.source = "/bench/source";
    spec.destination = "/bench/sink";
    auto created = monitor::Monitor::create(spec, monitor::MonitorPolicy{}, host);
    if (!created) {
        std::fprintf(stderr, "%s\n", created.error().message.c_str());
        return -1;
    }
    plexus::proto::Bytes payload;
    plexus::proto::encode_cbor(nlohmann::json{{"c", 0.9}, {"pad", std::string(pad)}}, payload);
    plexus::proto::Bytes record;
    plexus::proto::append_record(record, spec.source, 1, 1'700'000'000'000'000'000ull, payload);
    auto chunk = std::make_shared<Chunk>(record.size());
    std::memcpy(chunk->data(), record.data(), record.size());
    const Message message{chunk, {chunk->data(), record.size()}, 1};
    auto& monitor = **created;
    return median_ns_per_message([&] {
        Message copy = message;
        monitor.process(copy);
    });
}

}  // namespace

int main() {
    spdlog::set_level(spdlog::level::warn);
    constexpr const char* empty = "return true";
    constexpr const char* one_field = "return msg.data.c > 0.5";
    const double bare_empty = bare(empty);
    const double bare_field = bare(one_field);
    const double ours_empty = in_plexusd(empty);
    const double ours_field = in_plexusd(one_field);
    std::printf("Lua side of a port monitor, 64 B map, ns per message (median of %d runs of %d)\n", runs,
                messages_per_run);
    std::printf("  %-22s %10s %10s %8s\n", "accept", "bare Lua", "plexusd", "ratio");
    std::printf("  %-22s %10.1f %10.1f %7.2fx\n", "return true", bare_empty, ours_empty,
                ours_empty / bare_empty);
    std::printf("  %-22s %10.1f %10.1f %7.2fx\n", "msg.data.c > 0.5", bare_field, ours_field,
                ours_field / bare_field);
    return 0;
}
