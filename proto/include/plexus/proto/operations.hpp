#pragma once
// The requests and replies of the daemon's control operations (PROTOCOL.md, "Control operations"),
// one struct each, so that the daemon, libplexus, the CLI and the Python binding read and write the
// same fields by the same names. The name server's are in name_operations.hpp.
//
// Every request struct names its Op and has encode() (the body, "op" included) and decode(body);
// every reply struct has the same pair. decode never throws: a field of the wrong type is an Error
// ("malformed request: 'port' must be text"), which a server answers with code 2 (usage). A field
// that is missing takes the default written beside it, as the handlers always did, so older peers
// that leave a field out are still understood. Fields no struct names are ignored.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/ops.hpp"

namespace plexus::proto {

/// The reply of an op that answers only with its code: `{}` (a refusal's "error" is not part of it).
struct EmptyReply {
    nlohmann::json encode() const;                                 ///< `{}`
    static Result<EmptyReply> decode(const nlohmann::json& body);  ///< refuses only a non-map
};

/// `open`: a client opens a port.
struct OpenRequest {
    static constexpr Op op = Op::open;
    std::string port;                       ///< the port's name
    std::string policy = "strict";          ///< "strict" or "latest"; checked by the daemon
    std::optional<std::uint64_t> capacity;  ///< absent: the daemon's default
    bool serve = false;                     ///< the client answers calls on it (request/reply)
    nlohmann::json encode() const;          ///< the request body
    static Result<OpenRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `open`.
struct OpenReply {
    std::uint64_t handle = 0;                                     ///< what the port's data frames carry
    std::string node;                                             ///< the daemon's node
    nlohmann::json encode() const;                                ///< the reply body
    static Result<OpenReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `close`: a client closes one of its ports.
struct CloseRequest {
    static constexpr Op op = Op::close;
    std::uint64_t handle = 0;                                        ///< the handle `open` gave
    nlohmann::json encode() const;                                   ///< the request body
    static Result<CloseRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using CloseReply = EmptyReply;

/// `report`: counters a client keeps about one of its ports (what a bridge could not convert or
/// deliver), replacing those it reported before; `plexus stats` shows them under the port as
/// "reported". At most `max_counters`, each a name of at most `max_name` bytes and a whole number.
struct ReportRequest {
    static constexpr Op op = Op::report;
    static constexpr std::size_t max_counters = 64;
    static constexpr std::size_t max_name = 64;
    std::uint64_t handle = 0;                                         ///< the handle `open` gave
    nlohmann::json counters = nlohmann::json::object();               ///< name -> whole number
    nlohmann::json encode() const;                                    ///< the request body
    static Result<ReportRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using ReportReply = EmptyReply;

/// `shm`: without a handle, "this client maps regions"; with one, a region for that port.
struct ShmRequest {
    static constexpr Op op = Op::shm;
    std::optional<std::uint64_t> handle;  ///< the port to write through a region
    std::uint64_t bytes = 0;              ///< the payload about to be written (sent with a handle)
    nlohmann::json encode() const;        ///< the request body
    static Result<ShmRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `shm`: a region when one was asked for, else nothing.
struct ShmReply {
    std::optional<std::uint64_t> region;  ///< the region's id (its shm_region frame came first)
    std::uint64_t size = 0;               ///< its size in bytes
    nlohmann::json encode() const;        ///< the reply body
    static Result<ShmReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `connect`: SOURCE -> DESTINATION with a carrier; answered by the daemon of the source.
struct ConnectRequest {
    static constexpr Op op = Op::connect;
    std::string source;             ///< the sending port
    std::string destination;        ///< the receiving port
    std::string carrier;            ///< empty: the daemon chooses (local or tcp)
    bool strict = false;            ///< a possible overlap of constraints is a refusal, not a warning
    bool persist = false;           ///< the name server remembers the connection
    bool forwarded = false;         ///< sent on by a daemon that does not host the source
    nlohmann::json encode() const;  ///< the request body
    static Result<ConnectRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `connect`.
struct ConnectReply {
    std::string carrier;                ///< the carrier chosen
    std::vector<std::string> warnings;  ///< one per pair of constraints that can both be true
    nlohmann::json encode() const;      ///< the reply body
    static Result<ConnectReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `disconnect`: SOURCE -> DESTINATION; answered by the daemon of the source.
struct DisconnectRequest {
    static constexpr Op op = Op::disconnect;
    std::string source;             ///< the sending port
    std::string destination;        ///< the receiving port
    bool forwarded = false;         ///< sent on by a daemon that does not host the source
    nlohmann::json encode() const;  ///< the request body
    static Result<DisconnectRequest> decode(const nlohmann::json& body);  ///< from a request body
};
using DisconnectReply = EmptyReply;

/// `attach`: the first request on a link, asked of the daemon of the destination.
struct AttachRequest {
    static constexpr Op op = Op::attach;
    std::string source;       ///< the sending port, on the link's node
    std::string destination;  ///< the port here
    std::string carrier;      ///< the whole carrier text (the recv. clauses are built here)
    bool strict = false;      ///< as in connect
    std::string group;        ///< mcast only: the source's group, "A.B.C.D:PORT"; else empty
    std::string key;          ///< mcast with a secret: the key of the source's sealed stream (hex)
    /// mcast: the number of the source's next message. A receiver that joins takes no message
    /// numbered below it, so an old datagram replayed (it still opens under the key) cannot be
    /// the first message a new receiver hands on.
    std::uint64_t first_message = 0;
    nlohmann::json encode() const;                                    ///< the request body
    static Result<AttachRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `attach`: the sending daemon shapes its end after the destination's queue.
struct AttachReply {
    std::vector<std::string> warnings;      ///< as in connect
    std::string policy = "strict";          ///< the destination port's queue policy
    std::uint64_t capacity = 16;            ///< and its capacity
    std::optional<std::uint64_t> udp_port;  ///< udp: where to send the datagrams
    std::uint64_t stream = 0;               ///< udp: the stream they belong to
    std::string key;                ///< udp with a secret: the key to seal the stream's datagrams with (hex)
    nlohmann::json encode() const;  ///< the reply body
    static Result<AttachReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `stats`: the counters of this daemon, or of the one hosting `port`.
struct StatsRequest {
    static constexpr Op op = Op::stats;
    std::string port;               ///< empty: every port of the daemon asked
    bool forwarded = false;         ///< sent on by a daemon that does not host the port
    nlohmann::json encode() const;  ///< the request body
    static Result<StatsRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `stats`. Its document is the documented output of `plexus stats --json`
/// (PROTOCOL.md lists its fields) and programs read it whole, so it is carried as it is, not
/// re-typed field by field: inspect/stats_view.cpp is the one place that writes it.
struct StatsReply {
    nlohmann::json document = nlohmann::json::object();            ///< {"node", "address", "ports", "daemon"}
    nlohmann::json encode() const;                                 ///< the reply body
    static Result<StatsReply> decode(const nlohmann::json& body);  ///< refuses only a non-map
};

/// What `param` and `param_recv` share: which connection, and what to do with its monitors.
struct ParamArguments {
    std::string source;       ///< the connection's sending port
    std::string destination;  ///< and its receiving port
    std::string action;       ///< "get" or "set"; checked by the daemon
    nlohmann::json values;    ///< set: a map of the values; null when absent
};
/// `param`: `plexus param get|set`, answered by the daemon of the source.
struct ParamRequest : ParamArguments {
    static constexpr Op op = Op::param;
    bool forwarded = false;         ///< sent on by a daemon that does not host the source
    nlohmann::json encode() const;  ///< the request body
    static Result<ParamRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// `param_recv`: the receiving half of `param`, asked of the destination's daemon.
struct ParamRecvRequest : ParamArguments {
    static constexpr Op op = Op::param_recv;
    std::vector<std::uint64_t> send_took;  ///< places of the send-side monitors that took the values
    nlohmann::json encode() const;         ///< the request body
    static Result<ParamRecvRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// One monitor's parameters in a `param` answer.
struct MonitorParams {
    std::string script;    ///< the monitor's script (or plugin)
    std::string side;      ///< "send" or "recv"
    nlohmann::json param;  ///< what its getparam answered
};
/// The answer to `param` and `param_recv`.
struct ParamReply {
    std::vector<MonitorParams> monitors;  ///< every monitor of the connection, send side first
    bool any_setparam = false;            ///< some monitor took the values
    std::string action;                   ///< the action asked
    std::vector<std::uint64_t> took;      ///< param_recv: places of the recv-side monitors that took them
    nlohmann::json encode() const;        ///< the reply body
    static Result<ParamReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `ping` asked of a daemon: where this daemon, or the one hosting `port`, is. (The name server
/// answers `ping` too, with NamesPingReply.)
struct PingRequest {
    static constexpr Op op = Op::ping;
    std::string port;               ///< empty: this daemon
    bool forwarded = false;         ///< sent on by a daemon that does not host the port
    nlohmann::json encode() const;  ///< the request body
    static Result<PingRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// A daemon's answer to `ping`.
struct PingReply {
    std::string node;                                             ///< the daemon's node
    std::string address;                                          ///< its TCP address
    nlohmann::json encode() const;                                ///< the reply body
    static Result<PingReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `events`: the event container and arbitration of an input port.
struct EventsRequest {
    static constexpr Op op = Op::events;
    std::string port;               ///< the input port
    bool check = false;             ///< also look for constraints that can both be true
    bool forwarded = false;         ///< sent on by a daemon that does not host the port
    nlohmann::json encode() const;  ///< the request body
    static Result<EventsRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `events`: the documented output of `plexus events --json`, carried whole for
/// the reason StatsReply is; inspect/events_view.cpp writes it, tools/cli/events.cpp draws it.
struct EventsReply {
    nlohmann::json document = nlohmann::json::object();             ///< {"port", "node", "events", ...}
    nlohmann::json encode() const;                                  ///< the reply body
    static Result<EventsReply> decode(const nlohmann::json& body);  ///< refuses only a non-map
};

/// `node`: the daemon's node name, address and name server.
struct NodeRequest {
    static constexpr Op op = Op::node;
    nlohmann::json encode() const;                                  ///< the request body
    static Result<NodeRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `node`.
struct NodeReply {
    std::string node;       ///< the daemon's node name (may be empty)
    std::string address;    ///< its TCP address
    std::string names;      ///< its name server's address
    std::string http;       ///< its web endpoint's HOST:PORT (plexusd --http); empty when it serves none
    bool http_tls = false;  ///< the web endpoint speaks HTTPS (beyond loopback, with a secret)
    /// With the secret alone: the SHA-256 of the self-signed certificate it made at its start.
    std::string http_fingerprint;
    nlohmann::json encode() const;                                ///< the reply body
    static Result<NodeReply> decode(const nlohmann::json& body);  ///< from a reply body
};

/// `inspect`: a daemon's part of the whole system's view, for a web endpoint (docs/WEB.md).
struct InspectRequest {
    static constexpr Op op = Op::inspect;
    bool only_arbitration = false;  ///< "only": "arbitration" — the part the 20 Hz stream needs
    nlohmann::json encode() const;  ///< the request body
    static Result<InspectRequest> decode(const nlohmann::json& body);  ///< from a request body
};
/// The answer to `inspect`: {"node", "address", "stats", "arbitration"} (or {"node",
/// "arbitration"}), carried whole for the reason StatsReply is; inspect/node_view.cpp writes it.
struct InspectReply {
    nlohmann::json document = nlohmann::json::object();              ///< as docs/WEB.md shows
    nlohmann::json encode() const;                                   ///< the reply body
    static Result<InspectReply> decode(const nlohmann::json& body);  ///< from a reply body
};

// record_start, record_status, record_stop (docs/RECORDING.md)

/// Records ports of this daemon into a new file at `path` (on this daemon's machine) until
/// record_stop, until the session that asked closes, or until `max_bytes` are written.
struct RecordStartRequest {
    static constexpr Op op = Op::record_start;
    std::vector<std::string> ports;
    bool all = false;               ///< every port of this daemon (then `ports` may be empty)
    std::string path;               ///< absolute; never overwritten
    std::uint64_t max_bytes = 0;    ///< 0: no limit
    std::uint64_t split_bytes = 0;  ///< 0: one file; else a new file past this size
    /// Sent on by a daemon that hosts none of the ports: the recording then lives while someone
    /// asks record_status about it (a lease), not while a session does.
    bool forwarded = false;
    nlohmann::json encode() const;
    static Result<RecordStartRequest> decode(const nlohmann::json& body);
};
struct RecordStartReply {
    std::uint64_t id = 0;
    std::vector<std::string> ports;  ///< the ports recorded
    nlohmann::json encode() const;
    static Result<RecordStartReply> decode(const nlohmann::json& body);
};
/// record_status and record_stop ask about recording `id`.
struct RecordStatusRequest {
    static constexpr Op op = Op::record_status;
    std::uint64_t id = 0;
    std::string port;  ///< a recorded port: the request goes to the daemon that hosts it
    bool forwarded = false;
    nlohmann::json encode() const;
    static Result<RecordStatusRequest> decode(const nlohmann::json& body);
};
struct RecordStopRequest {
    static constexpr Op op = Op::record_stop;
    std::uint64_t id = 0;
    std::string port;  ///< as in record_status
    bool forwarded = false;
    nlohmann::json encode() const;
    static Result<RecordStopRequest> decode(const nlohmann::json& body);
};
/// The answer to both: {"id", "files", "messages", "decisions", "events", "bytes", "lost_messages",
/// "lost_bytes", "done", "error"}, as record/recorder.cpp writes it; carried whole.
struct RecordStatusReply {
    nlohmann::json document = nlohmann::json::object();
    nlohmann::json encode() const;
    static Result<RecordStatusReply> decode(const nlohmann::json& body);
};

}  // namespace plexus::proto
