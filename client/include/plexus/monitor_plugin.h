/* Plexus compiled port monitors: the C ABI between plexusd and a monitor plugin.
 *
 * A plugin is a shared library in one of plexusd's `--monitor-libs DIR` directories, named in a
 * carrier as `...+recv.portmonitor+type.so+file.NAME` (NAME.so). It has the life cycle and the
 * API of a Lua monitor (DESIGN.md, "Port monitors"): create with the clause's options, accept,
 * update, trig, getparam/setparam, destroy; events, constraints, publish, now and log through the
 * host table it gets at create.
 *
 * A plugin is trusted code: it runs in the daemon's process, with no time budget and no memory
 * cap. What the daemon does contain is an error returned (PLEXUS_MONITOR_ERROR) or a C++ exception
 * thrown by a callback: counted like a script error, the message dropped or passed as the clause's
 * onerror says, the monitor quarantined when it keeps failing.
 *
 * Threading: the daemon calls one monitor's callbacks one at a time (possibly on different
 * threads over its life); different monitors, of the same library too, may run at the same time,
 * so a plugin keeps its state in what create returns, not in globals.
 *
 * Versioning: the library exports `plexus_monitor_entry`, returning a descriptor whose
 * `abi_version` must equal the daemon's PLEXUS_MONITOR_ABI_VERSION; any change to a struct or a
 * signature here raises the version. A mismatch, a missing entry or a library that does not load
 * makes `plexus connect` fail with the reason.
 *
 * Values: the payload and parameters are read through `plexus_value` views (the bytes stay the
 * daemon's, valid until the callback returns) and built with a `plexus_builder`: no JSON, no
 * allocation on the per-message path.
 */
#ifndef PLEXUS_MONITOR_PLUGIN_H
#define PLEXUS_MONITOR_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The ABI this header describes. */
#define PLEXUS_MONITOR_ABI_VERSION 1u

/** Return codes of callbacks and host functions. */
#define PLEXUS_MONITOR_OK 0
#define PLEXUS_MONITOR_ERROR (-1)
/** accept: drop the message / pass it on. */
#define PLEXUS_MONITOR_DROP 0
#define PLEXUS_MONITOR_PASS 1
/** create: refuse the connection (connect fails, "refused the connection"). */
#define PLEXUS_MONITOR_REFUSE 1

/** Levels of plexus_host_api.log. */
#define PLEXUS_LOG_INFO 0
#define PLEXUS_LOG_WARN 1
#define PLEXUS_LOG_ERROR 2

/** The daemon's side of one monitor; passed back to every host function. Opaque. */
typedef struct plexus_host plexus_host;
/** A value being built (a replacement payload, getparam's table, a value to publish). Opaque. */
typedef struct plexus_builder plexus_builder;

/** A read-only view of one value (CBOR-encoded inside; read it through the host functions). */
typedef struct plexus_value {
    const unsigned char* bytes; /** NULL: absent (a missing map key, an index out of range) */
    size_t size;
} plexus_value;

/** What plexus_host_api.type says of a value. */
typedef enum plexus_type {
    PLEXUS_TYPE_ABSENT = 0,
    PLEXUS_TYPE_NULL,
    PLEXUS_TYPE_BOOL,
    PLEXUS_TYPE_INT,
    PLEXUS_TYPE_FLOAT,
    PLEXUS_TYPE_STRING,
    PLEXUS_TYPE_BYTES,
    PLEXUS_TYPE_ARRAY,
    PLEXUS_TYPE_MAP,
    PLEXUS_TYPE_INVALID /** malformed bytes */
} plexus_type;

/** One message, as accept and update see it. Valid until the callback returns. */
typedef struct plexus_message {
    const char* source; /** the source port, not NUL-terminated */
    size_t source_size;
    uint64_t seq;
    double time;       /** send time, seconds since the Unix epoch */
    plexus_value data; /** the payload */
} plexus_message;

/** One key of the clause (and source, destination, side, carrier first). A flag has value "". */
typedef struct plexus_option {
    const char* key;
    const char* value;
} plexus_option;

/** What the daemon gives a plugin. Functions returning int give PLEXUS_MONITOR_OK, or
 *  PLEXUS_MONITOR_ERROR with the reason in last_error. */
typedef struct plexus_host_api {
    /* --- the PortMonitor functions (recv side for events and constraints) --- */
    /** setEvent(name, lifetime): `lifetime_seconds` NULL for none; 0 to 86400 seconds. */
    int (*set_event)(plexus_host* host, const char* name, const double* lifetime_seconds);
    int (*unset_event)(plexus_host* host, const char* name);
    /** 1 if the event is in the container now, 0 if not, PLEXUS_MONITOR_ERROR. */
    int (*has_event)(plexus_host* host, const char* name);
    /** NULL clears the constraint. */
    int (*set_constraint)(plexus_host* host, const char* expression);
    /** The constraint's text, or NULL when none (or on error). Valid until the next host call. */
    const char* (*get_constraint)(plexus_host* host);
    /** Seconds: 0 stops trig. */
    int (*set_trig_interval)(plexus_host* host, double seconds);
    /** Writes a value on a port the daemon hosts for this monitor. */
    int (*publish)(plexus_host* host, const char* port, plexus_value value);
    /** Seconds since the Unix epoch, the daemon's clock. */
    double (*now)(plexus_host* host);
    /** A line in the daemon's log, tagged with the monitor. */
    void (*log)(plexus_host* host, int level, const char* text);
    /** Why the last failed host function failed. Valid until the next host call. */
    const char* (*last_error)(plexus_host* host);
    /** The reason a callback gives with its PLEXUS_MONITOR_ERROR (shown in stats and the log). */
    void (*set_error)(plexus_host* host, const char* text);

    /* --- reading values (never fail: a wrong type reads as absent / returns ERROR) --- */
    plexus_type (*type)(plexus_value value);
    int (*get_bool)(plexus_value value, int* out);
    int (*get_int)(plexus_value value, int64_t* out);
    /** An INT or a FLOAT, as a double. */
    int (*get_number)(plexus_value value, double* out);
    /** A STRING's bytes (not NUL-terminated). */
    int (*get_string)(plexus_value value, const char** data, size_t* size);
    int (*get_bytes)(plexus_value value, const unsigned char** data, size_t* size);
    /** Elements of an ARRAY, entries of a MAP, 0 otherwise. */
    size_t (*length)(plexus_value value);
    plexus_value (*array_at)(plexus_value array, size_t index);
    /** The value of a MAP's text key `key` (NUL-terminated); absent if missing. */
    plexus_value (*map_get)(plexus_value map, const char* key);
    /** The index-th entry of a MAP. */
    int (*map_entry)(plexus_value map, size_t index, plexus_value* key, plexus_value* value);

    /* --- building values: one top-level value; arrays and maps say their length first --- */
    /** A builder of the monitor's own (for publish); free it with builder_free. */
    plexus_builder* (*builder_new)(plexus_host* host);
    void (*builder_free)(plexus_builder* builder);
    /** Empties a builder to build another value. */
    void (*builder_reset)(plexus_builder* builder);
    /** The value built so far; absent until it is complete (or after a misuse). */
    plexus_value (*builder_value)(plexus_builder* builder);
    void (*put_null)(plexus_builder* builder);
    void (*put_bool)(plexus_builder* builder, int value);
    void (*put_int)(plexus_builder* builder, int64_t value);
    void (*put_float)(plexus_builder* builder, double value);
    void (*put_string)(plexus_builder* builder, const char* data, size_t size);
    void (*put_bytes)(plexus_builder* builder, const void* data, size_t size);
    /** Then `count` values follow. */
    void (*begin_array)(plexus_builder* builder, size_t count);
    /** Then `count` key, value pairs follow (keys: put_string). */
    void (*begin_map)(plexus_builder* builder, size_t count);
    /** A copy of a value read elsewhere (a part of the message, say). */
    void (*put_value)(plexus_builder* builder, plexus_value value);
} plexus_host_api;

/** The plugin's callbacks; any may be NULL (as a Lua monitor's are optional). `state` is what
 *  create stored. */
typedef struct plexus_monitor_plugin {
    /** PLEXUS_MONITOR_ABI_VERSION as the plugin was built. */
    uint32_t abi_version;
    /** A name for logs. */
    const char* name;
    /** Once, when the connection is made. Keep `host` and `api` in the state: they stay valid
     *  until destroy. OK, REFUSE, or ERROR (with set_error); after REFUSE or ERROR destroy is
     *  not called, so free what was made. */
    int (*create)(plexus_host* host, const plexus_host_api* api, const plexus_option* options,
                  size_t option_count, void** state);
    /** For each message: PASS, DROP, or ERROR. */
    int (*accept)(void* state, const plexus_message* message);
    /** For each accepted message: building a value in `replacement` replaces the payload; leaving
     *  it empty keeps the message. OK or ERROR. */
    int (*update)(void* state, const plexus_message* message, plexus_builder* replacement);
    /** Every set_trig_interval seconds. OK or ERROR. */
    int (*trig)(void* state);
    /** `plexus param get`: build a map in `out`. OK or ERROR. */
    int (*getparam)(void* state, plexus_builder* out);
    /** `plexus param set`: `values` is a map. OK or ERROR. */
    int (*setparam)(void* state, plexus_value values);
    /** When the connection goes away or the monitor is quarantined: free the state. */
    void (*destroy)(void* state);
} plexus_monitor_plugin;

/** The one symbol a plugin exports: its descriptor, valid while the library is loaded. */
#define PLEXUS_MONITOR_ENTRY_SYMBOL "plexus_monitor_entry"
typedef const plexus_monitor_plugin* (*plexus_monitor_entry_fn)(void);

#if defined(__GNUC__)
#define PLEXUS_MONITOR_EXPORT __attribute__((visibility("default")))
#else
#define PLEXUS_MONITOR_EXPORT
#endif

#ifdef __cplusplus
}
#endif

#endif /* PLEXUS_MONITOR_PLUGIN_H */
