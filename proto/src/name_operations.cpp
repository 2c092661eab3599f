// The name server's requests and replies, field by field (names as in PROTOCOL.md).
#include "plexus/proto/name_operations.hpp"

#include "body_fields.hpp"

namespace plexus::proto {

using body::Reader;
using body::reply_of;
using body::request_of;
using nlohmann::json;

json NamesPingReply::encode() const {
    json body{{"names", names}, {"auth_failures", auth_failures}, {"handshake_timeouts", handshake_timeouts}};
    if (tls_records_refused)
        body["tls_records_refused"] = *tls_records_refused;
    if (peers_refused)
        body["peers_refused"] = *peers_refused;
    if (identities_refused)
        body["identities_refused"] = *identities_refused;
    if (permission_refusals)
        body["permission_refusals"] = *permission_refusals;
    return body;
}
Result<NamesPingReply> NamesPingReply::decode(const json& body) {
    NamesPingReply out;
    Reader in(body, reply_of(Op::ping));
    in.text("names", out.names);
    in.whole("auth_failures", out.auth_failures);
    in.whole("handshake_timeouts", out.handshake_timeouts);
    in.whole("tls_records_refused", out.tls_records_refused);
    in.whole("peers_refused", out.peers_refused);
    in.whole("identities_refused", out.identities_refused);
    in.whole("permission_refusals", out.permission_refusals);
    return in.result(std::move(out));
}

// lookup

json LookupRequest::encode() const {
    return request_body(op, {{"port", port}});
}
Result<LookupRequest> LookupRequest::decode(const json& body) {
    LookupRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    return in.result(std::move(out));
}

json LookupReply::encode() const {
    return {{"port", port}, {"node", node}, {"address", address}};
}
Result<LookupReply> LookupReply::decode(const json& body) {
    LookupReply out;
    Reader in(body, reply_of(Op::lookup));
    in.text("port", out.port);
    in.text("node", out.node);
    in.text("address", out.address);
    return in.result(std::move(out));
}

// list

json ListRequest::encode() const {
    return request_body(op);
}
Result<ListRequest> ListRequest::decode(const json& body) {
    return Reader(body, request_of(op)).result(ListRequest{});
}

json ListReply::encode() const {
    return document;
}
Result<ListReply> ListReply::decode(const json& body) {
    Reader in(body, reply_of(Op::list));
    json ports;
    json connections;
    in.list("ports", ports);
    in.list("connections", connections);
    return in.result(ListReply{body});
}

// register_node

json RegisterNodeRequest::encode() const {
    return request_body(op, {{"node", node}, {"address", address}});
}
Result<RegisterNodeRequest> RegisterNodeRequest::decode(const json& body) {
    RegisterNodeRequest out;
    Reader in(body, request_of(op));
    in.text("node", out.node);
    in.text("address", out.address);
    return in.result(std::move(out));
}

// register_port

json RegisterPortRequest::encode() const {
    return request_body(op, {{"port", port}});
}
Result<RegisterPortRequest> RegisterPortRequest::decode(const json& body) {
    RegisterPortRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    return in.result(std::move(out));
}

json RegisterPortReply::encode() const {
    json listed = json::array();
    for (const auto& c : persistent)
        listed.push_back({{"source", c.source}, {"destination", c.destination}, {"carrier", c.carrier}});
    return {{"persistent", listed}};
}
Result<RegisterPortReply> RegisterPortReply::decode(const json& body) {
    RegisterPortReply out;
    Reader in(body, reply_of(Op::register_port));
    if (const auto* listed = in.find("persistent")) {
        if (!listed->is_array())
            in.wrong("persistent", "a list of maps");
        for (const auto& entry : listed->is_array() ? *listed : json::array()) {
            Reader connection(entry, reply_of(Op::register_port) + " connection");
            PersistentConnection c;
            connection.text("source", c.source);
            connection.text("destination", c.destination);
            connection.text("carrier", c.carrier);
            auto read = connection.result(std::move(c));
            if (!read)
                return read.error();
            out.persistent.push_back(std::move(*read));
        }
    }
    return in.result(std::move(out));
}

// unregister_port

json UnregisterPortRequest::encode() const {
    return request_body(op, {{"port", port}});
}
Result<UnregisterPortRequest> UnregisterPortRequest::decode(const json& body) {
    UnregisterPortRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    return in.result(std::move(out));
}

// add_connection

json AddConnectionRequest::encode() const {
    return request_body(
        op,
        {{"source", source}, {"destination", destination}, {"carrier", carrier}, {"persistent", persistent}});
}
Result<AddConnectionRequest> AddConnectionRequest::decode(const json& body) {
    AddConnectionRequest out;
    Reader in(body, request_of(op));
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.text("carrier", out.carrier);
    in.flag("persistent", out.persistent);
    return in.result(std::move(out));
}

// remove_connection

json RemoveConnectionRequest::encode() const {
    return request_body(op, {{"source", source}, {"destination", destination}, {"forget", forget}});
}
Result<RemoveConnectionRequest> RemoveConnectionRequest::decode(const json& body) {
    RemoveConnectionRequest out;
    Reader in(body, request_of(op));
    in.text("source", out.source);
    in.text("destination", out.destination);
    in.flag("forget", out.forget);
    return in.result(std::move(out));
}

// mcast_group

json McastGroupRequest::encode() const {
    return request_body(op, {{"port", port}});
}
Result<McastGroupRequest> McastGroupRequest::decode(const json& body) {
    McastGroupRequest out;
    Reader in(body, request_of(op));
    in.text("port", out.port);
    return in.result(std::move(out));
}

json McastGroupReply::encode() const {
    return {{"group", group}};
}
Result<McastGroupReply> McastGroupReply::decode(const json& body) {
    McastGroupReply out;
    Reader in(body, reply_of(Op::mcast_group));
    in.text("group", out.group);
    return in.result(std::move(out));
}

// discover

json DiscoverRequest::encode() const {
    auto body = request_body(op);
    if (!nonce.empty())
        body["nonce"] = nonce;
    return body;
}
Result<DiscoverRequest> DiscoverRequest::decode(const json& body) {
    DiscoverRequest out;
    Reader in(body, request_of(op));
    in.text("nonce", out.nonce);
    return in.result(std::move(out));
}

json DiscoverReply::encode() const {
    json body = {{"names", names}};
    if (!proof.empty())
        body["proof"] = proof;
    return body;
}
Result<DiscoverReply> DiscoverReply::decode(const json& body) {
    DiscoverReply out;
    Reader in(body, reply_of(Op::discover));
    in.text("names", out.names);
    in.text("proof", out.proof);
    return in.result(std::move(out));
}

}  // namespace plexus::proto
