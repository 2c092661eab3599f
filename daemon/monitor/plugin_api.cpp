#include "plugin_api.hpp"

#include <exception>
#include <new>

#include "plexus/proto/cbor.hpp"
#include "plugin_values.hpp"

namespace plexus::daemon::monitor {

namespace {

namespace values = plugin_values;

/// Runs a PortMonitor function for a plugin: OK, or ERROR with the reason in last_error. Nothing
/// thrown gets out: the caller is C.
template <typename Body>
int status_of(plexus_host* host, Body&& body) {
    if (!host || !host->monitor)
        return PLEXUS_MONITOR_ERROR;
    try {
        const proto::Status status = body(*host->monitor);
        if (status)
            return PLEXUS_MONITOR_OK;
        host->last_error = status.error().message;
    } catch (const std::exception& e) {
        host->last_error = e.what();
    }
    return PLEXUS_MONITOR_ERROR;
}

std::string text_of(const char* text) {
    return text ? std::string(text) : std::string();
}

int set_event(plexus_host* host, const char* name, const double* lifetime_seconds) {
    return status_of(host, [&](Monitor& monitor) {
        std::optional<double> lifetime;
        if (lifetime_seconds)
            lifetime = *lifetime_seconds;
        return monitor.set_event(text_of(name), lifetime);
    });
}

int unset_event(plexus_host* host, const char* name) {
    return status_of(host, [&](Monitor& monitor) { return monitor.unset_event(text_of(name)); });
}

int has_event(plexus_host* host, const char* name) {
    bool has = false;
    const int status = status_of(host, [&](Monitor& monitor) -> proto::Status {
        auto found = monitor.has_event(text_of(name));
        if (!found)
            return found.error();
        has = *found;
        return proto::Ok{};
    });
    return status == PLEXUS_MONITOR_OK ? (has ? 1 : 0) : status;
}

int set_constraint(plexus_host* host, const char* expression) {
    return status_of(host, [&](Monitor& monitor) {
        return monitor.set_constraint(expression ? std::optional<std::string>(expression) : std::nullopt);
    });
}

const char* get_constraint(plexus_host* host) {
    bool has = false;
    const int status = status_of(host, [&](Monitor& monitor) -> proto::Status {
        auto text = monitor.get_constraint();
        if (!text)
            return text.error();
        has = text->has_value();
        host->constraint = has ? **text : std::string();
        return proto::Ok{};
    });
    return status == PLEXUS_MONITOR_OK && has ? host->constraint.c_str() : nullptr;
}

int set_trig_interval(plexus_host* host, double seconds) {
    return status_of(host, [&](Monitor& monitor) { return monitor.set_trig_interval(seconds); });
}

int publish(plexus_host* host, const char* port, plexus_value value) {
    return status_of(host, [&](Monitor& monitor) -> proto::Status {
        const plexus_value item = values::first_item(value);
        if (!item.bytes)
            return proto::Error{"publish: the value is absent or malformed (an unfinished builder?)"};
        auto json = proto::decode_cbor_fast(proto::ByteView(item.bytes, item.size));
        if (!json)
            return proto::Error{"publish: " + json.error().message};
        return monitor.publish(text_of(port), *json);
    });
}

double now(plexus_host* host) {
    return host && host->monitor ? host->monitor->now() : 0.0;
}

void log(plexus_host* host, int level, const char* text) {
    if (!host || !host->monitor)
        return;
    try {
        const auto as = level >= PLEXUS_LOG_ERROR  ? Monitor::LogLevel::error
                        : level == PLEXUS_LOG_WARN ? Monitor::LogLevel::warn
                                                   : Monitor::LogLevel::info;
        host->monitor->log(as, text ? text : "");
    } catch (const std::exception&) {
        // A log line that cannot be written is lost; the plugin goes on.
    }
}

const char* last_error(plexus_host* host) {
    return host ? host->last_error.c_str() : "no host";
}

void set_error(plexus_host* host, const char* text) {
    if (!host)
        return;
    try {
        host->error = text_of(text);
    } catch (const std::exception&) {
        host->error.clear();
    }
}

plexus_builder* builder_new(plexus_host*) {
    return new (std::nothrow) plexus_builder;
}

void builder_free(plexus_builder* builder) {
    delete builder;
}

void builder_reset(plexus_builder* builder) {
    if (builder)
        values::reset(builder);
}

plexus_value builder_value(plexus_builder* builder) {
    return builder ? values::value_of(builder) : plexus_value{nullptr, 0};
}

/// The builder functions append to vectors: out of memory marks the builder spoiled instead of
/// throwing into the plugin.
template <typename Body>
void building(plexus_builder* builder, Body&& body) {
    if (!builder)
        return;
    try {
        body(builder);
    } catch (const std::exception&) {
        if (builder->misuse.empty())
            builder->misuse = "out of memory while building";
    }
}

void put_null(plexus_builder* b) {
    building(b, [](plexus_builder* b) { values::put_null(b); });
}
void put_bool(plexus_builder* b, int value) {
    building(b, [value](plexus_builder* b) { values::put_bool(b, value); });
}
void put_int(plexus_builder* b, std::int64_t value) {
    building(b, [value](plexus_builder* b) { values::put_int(b, value); });
}
void put_float(plexus_builder* b, double value) {
    building(b, [value](plexus_builder* b) { values::put_float(b, value); });
}
void put_string(plexus_builder* b, const char* data, std::size_t size) {
    building(b, [=](plexus_builder* b) { values::put_string(b, data, size); });
}
void put_bytes(plexus_builder* b, const void* data, std::size_t size) {
    building(b, [=](plexus_builder* b) { values::put_bytes(b, data, size); });
}
void begin_array(plexus_builder* b, std::size_t count) {
    building(b, [count](plexus_builder* b) { values::begin_array(b, count); });
}
void begin_map(plexus_builder* b, std::size_t count) {
    building(b, [count](plexus_builder* b) { values::begin_map(b, count); });
}
void put_value(plexus_builder* b, plexus_value value) {
    building(b, [value](plexus_builder* b) { values::put_value(b, value); });
}

const plexus_host_api api_table = {
    set_event,
    unset_event,
    has_event,
    set_constraint,
    get_constraint,
    set_trig_interval,
    publish,
    now,
    log,
    last_error,
    set_error,
    values::type,
    values::get_bool,
    values::get_int,
    values::get_number,
    values::get_string,
    values::get_bytes,
    values::length,
    values::array_at,
    values::map_get,
    values::map_entry,
    builder_new,
    builder_free,
    builder_reset,
    builder_value,
    put_null,
    put_bool,
    put_int,
    put_float,
    put_string,
    put_bytes,
    begin_array,
    begin_map,
    put_value,
};

}  // namespace

const plexus_host_api& plugin_host_api() {
    return api_table;
}

}  // namespace plexus::daemon::monitor
