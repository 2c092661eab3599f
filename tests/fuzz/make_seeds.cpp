// Writes the binary seed corpora of tests/fuzz/corpus/ (the text ones come from the tests' and
// configs' own strings, see docs/FUZZING.md): the frames, records, datagrams and payloads the unit
// and integration tests send, made with the real encoders so that they stay what the wire carries.
// Usage: fuzz_make_seeds DIR   (writes DIR/TARGET/NAME for each target that takes bytes)
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/mcap/writer.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/datagram.hpp"
#include "plexus/proto/discovery.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/rings.hpp"
#include "plexus/proto/shm.hpp"
#include "plexus/proto/varint.hpp"

namespace proto = plexus::proto;
using nlohmann::json;

namespace {

std::filesystem::path root;

void seed(const std::string& target, const std::string& name, const proto::Bytes& bytes) {
    std::filesystem::create_directories(root / target);
    std::ofstream out(root / target / name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

proto::Bytes cbor(const json& value) {
    proto::Bytes out;
    proto::encode_cbor(value, out);
    return out;
}

proto::Bytes fields_of(const proto::Bytes& frame) {
    const auto decoded = proto::FrameDecoder().decode(frame);
    return {decoded.fields.begin(), decoded.fields.end()};
}

/// Small recordings as plexus::mcap::Writer makes them: zstd and plain chunks, with and without
/// summary, and an empty one.
void mcap_seed(const std::string& name, const std::string& compression, bool summary, int messages) {
    std::filesystem::create_directories(root / "mcap_reader");
    const auto path = (root / "mcap_reader" / name).string();
    std::filesystem::remove(path);  // the writer never replaces a file
    plexus::mcap::WriterOptions options;
    options.compression = compression;
    options.write_summary = summary;
    options.chunk_bytes = 256;  // several chunks even in a small seed
    auto writer = plexus::mcap::Writer::create(path, options);
    if (!writer) {
        std::cerr << writer.error().message << "\n";
        return;
    }
    const auto schema = (*writer)->add_schema("Pose", "jsonschema", proto::as_bytes(R"({"type":"object"})"));
    const auto pose = (*writer)->add_channel("/robot/pose:o", "json", {{"carrier", "tcp"}}, schema);
    const auto image = (*writer)->add_channel("/camera/image:o", "cbor", {});
    (void)(*writer)->write_metadata("recording", {{"host", "robot"}});
    for (int i = 0; i < messages; ++i) {
        const std::string text = R"({"x":)" + std::to_string(i) + "}";
        (void)(*writer)->write_message(i % 2 == 0 ? *pose : *image, static_cast<std::uint32_t>(i),
                                       1000 + static_cast<std::uint64_t>(i), 999, proto::as_bytes(text));
    }
    (void)(*writer)->close();
}

/// The same file with every CRC set to 0 ("not computed", which readers accept): without them
/// nearly every mutation fails a CRC, and the fuzzer never reaches the parsers behind it.
void mcap_seed_without_crcs(const std::string& name, const std::string& from) {
    std::ifstream in(root / "mcap_reader" / from, std::ios::binary);
    proto::Bytes bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    const auto zero = [&](std::size_t at, std::size_t count) {
        for (std::size_t i = 0; i < count && at + i < bytes.size(); ++i)
            bytes[at + i] = 0;
    };
    // Walk the top-level records (opcode u8, length u64 little-endian; layout in proto/mcap/src/format.hpp).
    std::size_t at = 8;
    while (at + 9 <= bytes.size()) {
        std::uint64_t length = 0;
        for (std::size_t i = 0; i < 8; ++i)
            length |= std::uint64_t{bytes[at + 1 + i]} << (8 * i);
        const std::size_t content = at + 9;
        if (bytes[at] == 0x06)  // chunk: start u64, end u64, uncompressed size u64, then the CRC
            zero(content + 24, 4);
        else if (bytes[at] == 0x0F)  // data end: the CRC
            zero(content, 4);
        else if (bytes[at] == 0x02)  // footer: summary start, summary offset start, then the CRC
            zero(content + 16, 4);
        if (bytes[at] == 0x02 || length > bytes.size() - content)
            break;
        at = content + static_cast<std::size_t>(length);
    }
    seed("mcap_reader", name, bytes);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: fuzz_make_seeds DIR\n";
        return 2;
    }
    root = argv[1];

    // Payloads: what the tests and the fetch robot's components write (control_test's sample body,
    // numbers at the edges, blobs, an image-like array, nested maps).
    const json sample_body = {{"op", "connect"}, {"src", "/a/out"},
                              {"dst", "/b/in"},  {"carrier", "tcp+recv.priority+tc.0.5"},
                              {"persist", true}, {"weights", {1, -2.5, nullptr}}};
    const std::vector<std::pair<std::string, json>> payloads{
        {"sample_body", sample_body},
        {"numbers", json{{"i", -7},
                         {"u", 18446744073709551615ull},
                         {"big", 9223372036854775807ll},
                         {"f", 0.03},
                         {"neg", -1e300},
                         {"zero", 0}}},
        {"blob", json::binary({0, 1, 2, 255, 128})},
        {"blob_subtype", json::binary({1, 2, 3}, 42)},
        {"text", "héllo"},
        {"object_pose", json{{"x", 0.4}, {"y", -0.1}, {"z", 0.03}, {"held", false}, {"label", "cup"}}},
        {"array", json::array({1, 2, 3, json::array({4, 5}), json::object()})},
        {"empty_array", json::array()},
        {"empty_object", json::object()},
        {"null", nullptr},
        {"nested", json{{"a", {{"b", {{"c", {1, "two", 3.0}}}}}}}},
    };
    for (const auto& [name, value] : payloads) {
        seed("cbor", name, cbor(value));
        seed("lua_value", name, cbor(value));
    }
    // Indefinite lengths and a half float, which to_cbor never writes but peers may.
    seed("cbor", "indefinite",
         {0x9f, 0x01, 0x7f, 0x61, 0x61, 0xff, 0xbf, 0x61, 0x6b, 0xf9, 0x3c, 0x00, 0xff, 0xff});
    seed("lua_value", "indefinite",
         {0x9f, 0x01, 0x7f, 0x61, 0x61, 0xff, 0xbf, 0x61, 0x6b, 0xf9, 0x3c, 0x00, 0xff, 0xff});

    // Frames as sessions send them (frame_test, control_test, hello_test, shm_test).
    const proto::Bytes payload = cbor(payloads[4].second);
    proto::Bytes record;
    proto::append_record(record, "/world/object", 42, 1700000000123456789ull, payload);
    std::vector<std::pair<std::string, proto::Bytes>> frames;
    proto::Hello hello{proto::protocol_version, "daemon", "arm"};
    hello.nonce.fill(7);
    hello.has_secret = true;
    frames.emplace_back("hello", proto::encode_hello(hello));
    frames.emplace_back("hello_client", proto::encode_hello({proto::protocol_version, "client", ""}));
    frames.emplace_back("request",
                        proto::encode_request({7, {{"op", "connect"}, {"src", "/a"}, {"dst", "/b"}}}));
    frames.emplace_back("request_big_id", proto::encode_request({1ull << 40, sample_body}));
    frames.emplace_back("reply",
                        proto::encode_reply({7, proto::ReplyCode::refused, {{"error", "no such port"}}}));
    frames.emplace_back("reply_ok",
                        proto::encode_reply({5, proto::ReplyCode::ok, {{"ports", {"/a", "/b"}}}}));
    frames.emplace_back("error", proto::make_error_frame("frame length 4294967296 exceeds limit 67108864"));
    proto::Bytes data;
    proto::append_data_frame(data, 3, record);
    frames.emplace_back("data", data);
    proto::Bytes records;
    proto::append_batch_record(records, "/world/object", 1, 10, payload);
    proto::append_batch_record(records, "/world/object", 2, 20, {});
    proto::Bytes batch;
    proto::append_batch_frame_prefix(batch, 3, 2, records.size());
    batch.insert(batch.end(), records.begin(), records.end());
    frames.emplace_back("data_batch", batch);
    proto::Bytes place;
    proto::append_shm_place(place, {1, 4096, 1 << 20}, "/camera/image", 9, 123);
    proto::Bytes shm_data;
    proto::append_shm_frame_prefix(shm_data, 3, place.size());
    shm_data.insert(shm_data.end(), place.begin(), place.end());
    frames.emplace_back("data_shm", shm_data);
    frames.emplace_back("shm_region", proto::make_shm_region_frame({1, 8u << 20, true}));
    frames.emplace_back("shm_release", proto::make_shm_number_frame(proto::FrameType::shm_release, 4));
    frames.emplace_back("shm_region_gone",
                        proto::make_shm_number_frame(proto::FrameType::shm_region_gone, 1));
    frames.emplace_back("shm_free", proto::make_shm_free_frame(1, 4096));
    frames.emplace_back("rings_request", proto::make_rings_request(0));
    frames.emplace_back("rings_request_small", proto::make_rings_request(64 * 1024));
    frames.emplace_back("rings_answer", proto::make_rings_answer({512 * 1024, ""}));
    frames.emplace_back(
        "rings_refused",
        proto::make_rings_answer({0, "shared-memory rings are off on this daemon (shm_ring_bytes is 0)"}));
    proto::Bytes stream;
    for (const auto& [name, frame] : frames) {
        seed("frame_decoder", name, frame);
        seed("frame_fields", name, frame);
        stream.insert(stream.end(), frame.begin(), frame.end());
    }
    seed("frame_decoder", "stream", stream);
    seed("frame_decoder", "lying_length", {0xff, 0xff, 0xff, 0xff, 0x0f, 4, 0, 1, 2});

    // Records and the fields of data and batch frames (message_test).
    seed("message", "record", record);
    seed("message", "data_fields", fields_of(data));
    seed("message", "batch_fields", fields_of(batch));
    proto::Bytes empty_record;
    proto::append_record(empty_record, "", 0, 0, {});
    seed("message", "empty_record", empty_record);

    // Datagrams of the udp carrier (datagram_test) and the discovery exchange.
    proto::Bytes datagram;
    proto::append_datagram_header(datagram, {5, 0, record.size(), 1400, 0, false});
    datagram.insert(datagram.end(), record.begin(), record.end());
    seed("frame_fields", "datagram", datagram);
    proto::Bytes fragment;
    proto::append_datagram_header(fragment, {5, 9, 3000, 1400, 2, true});
    fragment.insert(fragment.end(), 200, 0x5a);
    fragment.insert(fragment.end(), proto::datagram_sealed_tag_size, 0x11);
    seed("frame_fields", "datagram_fragment_sealed", fragment);
    seed("frame_fields", "discovery_reply", proto::discovery_reply(3, {"0.0.0.0", 10100}));
    seed("frame_fields", "discovery_reply_host", proto::discovery_reply(3, {"192.168.1.20", 10100}));

    // What the name server is sent (name_client.cpp's requests, discovery_query()).
    const std::vector<std::pair<std::string, json>> name_requests{
        {"ping", {{"op", "ping"}}},
        {"lookup", {{"op", "lookup"}, {"port", "/world/object"}}},
        {"list", {{"op", "list"}}},
        {"register_node", {{"op", "register_node"}, {"node", "arm"}, {"address", "127.0.0.1:40001"}}},
        {"register_port", {{"op", "register_port"}, {"port", "/arm/state"}}},
        {"unregister_port", {{"op", "unregister_port"}, {"port", "/arm/state"}}},
        {"add_connection",
         {{"op", "add_connection"},
          {"source", "/a/out"},
          {"destination", "/b/in"},
          {"carrier", "tcp"},
          {"persistent", true}}},
        {"remove_connection", {{"op", "remove_connection"}, {"source", "/a/out"}, {"destination", "/b/in"}}},
        {"mcast_group", {{"op", "mcast_group"}, {"port", "/world/object"}}},
    };
    proto::Bytes session;
    session = proto::encode_hello({proto::protocol_version, "daemon", "arm"});
    std::uint64_t id = 1;
    for (const auto& [name, body] : name_requests) {
        const auto frame = proto::encode_request({id++, body});
        seed("name_request", name, frame);
        session.insert(session.end(), frame.begin(), frame.end());
    }
    seed("name_request", "session", session);
    seed("name_request", "discover", proto::discovery_query());
    mcap_seed("chunked_zstd", "zstd", true, 30);
    mcap_seed("chunked_plain", "", true, 20);
    mcap_seed("no_summary", "zstd", false, 20);
    mcap_seed("empty", "zstd", true, 0);
    mcap_seed_without_crcs("chunked_zstd_no_crcs", "chunked_zstd");
    mcap_seed_without_crcs("chunked_plain_no_crcs", "chunked_plain");
    mcap_seed_without_crcs("no_summary_no_crcs", "no_summary");
    std::cout << "seeds written under " << root << "\n";
    return 0;
}
