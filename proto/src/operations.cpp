// The daemon's requests and replies, field by field (the names are PROTOCOL.md's and must stay
// so: the Python client, older peers and the tests read them).
#include "plexus/proto/operations.hpp"

#include "body_fields.hpp"

namespace plexus::proto {

using body::Reader;
using body::reply_of;
using body::request_of;
using nlohmann::json;

namespace {
/// A request body with "op" and, only when it is set, "forwarded" (what older peers send).
json request_with(Op op, json fields, bool forwarded = false) {
    json out = request_body(op, std::move(fields));
    if (forwarded)
        out["forwarded"] = true;
    return out;
}
}  // namespace

json EmptyReply::encode() const {
    return json::object();
}
Result<EmptyReply> EmptyReply::decode(const json& body) {
    return Reader(body, "reply").result(EmptyReply{});
}

// open

json OpenRequest::encode() const {
    json fields = {{"port", port}, {"policy", policy}};
    if (capacity)
        fields["capacity"] = *capacity;
    if (serve)
        fields["serve"] = true;
    return request_with(op, std::move(fields));
}
Result<OpenRequest> OpenRequest::decode(const json& body) {
    OpenRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    in.text("policy", out.policy);
    in.whole("capacity", out.capacity);
    in.flag("serve", out.serve);
    return in.result(std::move(out));
}

json OpenReply::encode() const {
    return {{"handle", handle}, {"node", node}};
}
Result<OpenReply> OpenReply::decode(const json& body) {
    OpenReply out;
    Reader in(body, reply_of(Op::open));
    in.whole("handle", out.handle);
    in.text("node", out.node);
    return in.result(std::move(out));
}

// close

json CloseRequest::encode() const {
    return request_with(op, {{"handle", handle}});
}
Result<CloseRequest> CloseRequest::decode(const json& body) {
    CloseRequest out;
    Reader in(body, request_of(op));
    in.whole("handle", out.handle);
    return in.result(out);
}

// report

json ReportRequest::encode() const {
    return request_with(op, {{"handle", handle}, {"counters", counters}});
}
Result<ReportRequest> ReportRequest::decode(const json& body) {
    ReportRequest out;
    Reader in(body, request_of(op));
    in.whole("handle", out.handle);
    in.map("counters", out.counters);
    if (out.counters.size() > max_counters)
        in.wrong("counters", "a map of at most 64 counters");
    for (const auto& [name, value] : out.counters.items()) {
        if (name.empty() || name.size() > max_name || !body::is_whole(value))
            in.wrong("counters", "a map of names (1 to 64 bytes) to whole numbers");
    }
    return in.result(std::move(out));
}

// shm

json ShmRequest::encode() const {
    if (!handle)
        return request_with(op, json::object());
    return request_with(op, {{"handle", *handle}, {"bytes", bytes}});
}
Result<ShmRequest> ShmRequest::decode(const json& body) {
    ShmRequest out;
    Reader in(body, request_of(op));
    in.whole("handle", out.handle);
    in.whole("bytes", out.bytes);
    return in.result(out);
}

json ShmReply::encode() const {
    if (!region)
        return json::object();
    return {{"region", *region}, {"size", size}};
}
Result<ShmReply> ShmReply::decode(const json& body) {
    ShmReply out;
    Reader in(body, reply_of(Op::shm));
    in.whole("region", out.region);
    in.whole("size", out.size);
    return in.result(out);
}

// connect

json ConnectRequest::encode() const {
    return request_with(op,
                        {{"source", source},
                         {"destination", destination},
                         {"carrier", carrier},
                         {"strict", strict},
                         {"persist", persist}},
                        forwarded);
}
Result<ConnectRequest> ConnectRequest::decode(const json& body) {
    ConnectRequest out;
    Reader in(body, request_of(op));
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.text("carrier", out.carrier);
    in.flag("strict", out.strict);
    in.flag("persist", out.persist);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json ConnectReply::encode() const {
    return {{"carrier", carrier}, {"warnings", warnings}};
}
Result<ConnectReply> ConnectReply::decode(const json& body) {
    ConnectReply out;
    Reader in(body, reply_of(Op::connect));
    in.text("carrier", out.carrier);
    in.texts("warnings", out.warnings);
    return in.result(std::move(out));
}

// disconnect

json DisconnectRequest::encode() const {
    return request_with(op, {{"source", source}, {"destination", destination}}, forwarded);
}
Result<DisconnectRequest> DisconnectRequest::decode(const json& body) {
    DisconnectRequest out;
    Reader in(body, request_of(op));
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

// attach

json AttachRequest::encode() const {
    json fields = {
        {"source", source}, {"destination", destination}, {"carrier", carrier}, {"strict", strict}};
    if (!group.empty())
        fields["group"] = group;
    if (!key.empty())
        fields["key"] = key;
    if (first_message != 0)
        fields["first_message"] = first_message;
    return request_with(op, std::move(fields));
}
Result<AttachRequest> AttachRequest::decode(const json& body) {
    AttachRequest out;
    Reader in(body, request_of(op));
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.text("carrier", out.carrier);
    in.flag("strict", out.strict);
    in.text("group", out.group);
    in.text("key", out.key);
    in.whole("first_message", out.first_message);
    return in.result(std::move(out));
}

json AttachReply::encode() const {
    json out = {{"warnings", warnings}, {"policy", policy}, {"capacity", capacity}};
    if (udp_port) {
        out["udp_port"] = *udp_port;
        out["stream"] = stream;
    }
    if (!key.empty())
        out["key"] = key;
    return out;
}
Result<AttachReply> AttachReply::decode(const json& body) {
    AttachReply out;
    Reader in(body, reply_of(Op::attach));
    in.texts("warnings", out.warnings);
    in.text("policy", out.policy);
    in.whole("capacity", out.capacity);
    in.whole("udp_port", out.udp_port);
    in.whole("stream", out.stream);
    in.text("key", out.key);
    return in.result(std::move(out));
}

// stats

json StatsRequest::encode() const {
    return request_with(op, {{"port", port}}, forwarded);
}
Result<StatsRequest> StatsRequest::decode(const json& body) {
    StatsRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json StatsReply::encode() const {
    return document;
}
Result<StatsReply> StatsReply::decode(const json& body) {
    return Reader(body, reply_of(Op::stats)).result(StatsReply{body});
}

// param and param_recv

namespace {
json param_fields(const ParamArguments& arguments) {
    json fields = {
        {"action", arguments.action}, {"source", arguments.source}, {"destination", arguments.destination}};
    if (!arguments.values.is_null())
        fields["values"] = arguments.values;
    return fields;
}
void read_param_fields(Reader& in, ParamArguments& out) {
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.text("action", out.action);
    in.map("values", out.values);
}
}  // namespace

json ParamRequest::encode() const {
    return request_with(op, param_fields(*this), forwarded);
}
Result<ParamRequest> ParamRequest::decode(const json& body) {
    ParamRequest out;
    Reader in(body, request_of(op));
    read_param_fields(in, out);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json ParamRecvRequest::encode() const {
    json fields = param_fields(*this);
    fields["send_took"] = send_took;
    return request_with(op, std::move(fields));
}
Result<ParamRecvRequest> ParamRecvRequest::decode(const json& body) {
    ParamRecvRequest out;
    Reader in(body, request_of(op));
    read_param_fields(in, out);
    in.wholes("send_took", out.send_took);
    return in.result(std::move(out));
}

json ParamReply::encode() const {
    json listed = json::array();
    for (const auto& monitor : monitors)
        listed.push_back({{"script", monitor.script}, {"side", monitor.side}, {"param", monitor.param}});
    return {{"monitors", listed}, {"any_setparam", any_setparam}, {"action", action}, {"took", took}};
}
Result<ParamReply> ParamReply::decode(const json& body) {
    ParamReply out;
    Reader in(body, reply_of(Op::param));
    if (const auto* listed = in.find("monitors")) {
        if (!listed->is_array())
            in.wrong("monitors", "a list of maps");
        for (const auto& entry : listed->is_array() ? *listed : json::array()) {
            Reader monitor(entry, reply_of(Op::param) + " monitor");
            MonitorParams params;
            monitor.text("script", params.script);
            monitor.text("side", params.side);
            if (const auto* param = monitor.find("param"))
                params.param = *param;
            auto read = monitor.result(std::move(params));
            if (!read)
                return read.error();
            out.monitors.push_back(std::move(*read));
        }
    }
    in.flag("any_setparam", out.any_setparam);
    in.text("action", out.action);
    in.wholes("took", out.took);
    return in.result(std::move(out));
}

// ping

json PingRequest::encode() const {
    return request_with(op, {{"port", port}}, forwarded);
}
Result<PingRequest> PingRequest::decode(const json& body) {
    PingRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json PingReply::encode() const {
    return {{"node", node}, {"address", address}};
}
Result<PingReply> PingReply::decode(const json& body) {
    PingReply out;
    Reader in(body, reply_of(Op::ping));
    in.text("node", out.node);
    in.text("address", out.address);
    return in.result(std::move(out));
}

// events

json EventsRequest::encode() const {
    return request_with(op, {{"port", port}, {"check", check}}, forwarded);
}
Result<EventsRequest> EventsRequest::decode(const json& body) {
    EventsRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    in.flag("check", out.check);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json EventsReply::encode() const {
    return document;
}
Result<EventsReply> EventsReply::decode(const json& body) {
    return Reader(body, reply_of(Op::events)).result(EventsReply{body});
}

// node

json NodeRequest::encode() const {
    return request_with(op, json::object());
}
Result<NodeRequest> NodeRequest::decode(const json& body) {
    return Reader(body, request_of(op)).result(NodeRequest{});
}

json NodeReply::encode() const {
    json out = {{"node", node}, {"address", address}, {"names", names}, {"http", http}};
    if (http_tls)
        out["http_tls"] = true;
    if (!http_fingerprint.empty())
        out["http_fingerprint"] = http_fingerprint;
    return out;
}
Result<NodeReply> NodeReply::decode(const json& body) {
    NodeReply out;
    Reader in(body, reply_of(Op::node));
    in.text("node", out.node);
    in.text("address", out.address);
    in.text("names", out.names);
    in.text("http", out.http);
    in.flag("http_tls", out.http_tls);
    in.text("http_fingerprint", out.http_fingerprint);
    return in.result(std::move(out));
}

// inspect

json InspectRequest::encode() const {
    json fields = json::object();
    if (only_arbitration)
        fields["only"] = "arbitration";
    return request_with(op, std::move(fields));
}
Result<InspectRequest> InspectRequest::decode(const json& body) {
    std::string only;
    Reader in(body, request_of(op));
    in.text("only", only);
    return in.result(InspectRequest{only == "arbitration"});
}

json InspectReply::encode() const {
    return document;
}
Result<InspectReply> InspectReply::decode(const json& body) {
    return Reader(body, reply_of(Op::inspect)).result(InspectReply{body});
}

// record_start, record_status, record_stop

json RecordStartRequest::encode() const {
    return request_with(op,
                        {{"ports", ports},
                         {"all", all},
                         {"path", path},
                         {"max_bytes", max_bytes},
                         {"split_bytes", split_bytes}},
                        forwarded);
}
Result<RecordStartRequest> RecordStartRequest::decode(const json& body) {
    RecordStartRequest out;
    Reader in(body, request_of(op));
    in.texts("ports", out.ports);
    in.flag("all", out.all);
    in.text("path", out.path);
    in.whole("max_bytes", out.max_bytes);
    in.whole("split_bytes", out.split_bytes);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json RecordStartReply::encode() const {
    return {{"id", id}, {"ports", ports}};
}
Result<RecordStartReply> RecordStartReply::decode(const json& body) {
    RecordStartReply out;
    Reader in(body, reply_of(Op::record_start));
    in.whole("id", out.id);
    in.texts("ports", out.ports);
    return in.result(std::move(out));
}

json RecordStatusRequest::encode() const {
    return request_with(op, {{"id", id}, {"port", port}}, forwarded);
}
Result<RecordStatusRequest> RecordStatusRequest::decode(const json& body) {
    RecordStatusRequest out;
    Reader in(body, request_of(op));
    in.whole("id", out.id);
    in.text("port", out.port);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json RecordStopRequest::encode() const {
    return request_with(op, {{"id", id}, {"port", port}}, forwarded);
}
Result<RecordStopRequest> RecordStopRequest::decode(const json& body) {
    RecordStopRequest out;
    Reader in(body, request_of(op));
    in.whole("id", out.id);
    in.text("port", out.port);
    in.flag("forwarded", out.forwarded);
    return in.result(std::move(out));
}

json RecordStatusReply::encode() const {
    return document;
}
Result<RecordStatusReply> RecordStatusReply::decode(const json& body) {
    return Reader(body, reply_of(Op::record_status)).result(RecordStatusReply{body});
}

}  // namespace plexus::proto
