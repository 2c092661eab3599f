// The daemons' TLS 1.3 record layer (daemon/net/tls_records.hpp) against a peer that holds the
// link's keys and sends whatever it likes: an authenticated but hostile daemon. Two TlsRecords
// share mirrored secrets; the input is a script of what the sending one seals and what the wire
// does to it, and the receiving one opens every whole record, as ByteStream does.
//
// The script: its first byte picks the suite (AES-128-GCM, AES-256-GCM, ChaCha20-Poly1305) and
// whether keys change every 2 records; then each step is one byte (which, % 5) and its arguments:
//   0 LEN BYTES   application data of LEN (0-255) bytes, sealed by seal()
//   1 TYPE LEN BYTES   one record of content type TYPE holding BYTES (alerts, handshake messages
//                 of any shape: key updates, tickets, garbage; any other type)
//   2 LEN BYTES   raw bytes on the wire (a forged or cut record)
//   3 AT XOR      flips bits of a byte already on the wire (AT from the end)
//   4             a KeyUpdate that asks for an answer, by the sender's own key schedule
//
// Properties: opening never crashes, reads or writes out of its record (ASan), or hands on more
// than max_plain bytes from a record; application data sealed by seal() comes out as it went in
// while the wire is untouched; once a record fails, the link ends (nothing is opened after).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_check.hpp"
#include "net/tls_records.hpp"

namespace net = plexus::daemon;
namespace proto = plexus::proto;

namespace {

/// Reads the script; past its end every read gives zeros (and done() says so).
struct Script {
    const std::uint8_t* data;
    std::size_t size;
    std::size_t at = 0;
    bool done() const { return at >= size; }
    std::uint8_t byte() { return at < size ? data[at++] : 0; }
    proto::ByteView bytes(std::size_t count) {
        const std::size_t taken = std::min(count, size - std::min(at, size));
        const proto::ByteView view(data + std::min(at, size), taken);
        at += taken;
        return view;
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    Script script{data, size};
    const std::uint8_t setup = script.byte();
    static const std::uint16_t suites[] = {0x1301, 0x1302, 0x1303};
    const std::uint16_t suite = suites[setup % 3];
    const std::size_t secret_size = suite == 0x1302 ? 48 : 32;
    const std::uint64_t per_key = (setup & 0x80) != 0 ? 2 : net::TlsRecords::default_records_per_key;
    const proto::Bytes client(secret_size, 0x11);
    const proto::Bytes server(secret_size, 0x22);
    auto sender = net::TlsRecords::from_secrets(suite, client, server, per_key);
    auto receiver = net::TlsRecords::from_secrets(suite, server, client, per_key);
    PLEXUS_FUZZ_CHECK(sender && receiver);

    net::RecordBuffer wire;
    proto::Bytes sent_data;  // what seal() carried, while the wire is as sealed
    bool wire_intact = true;
    for (int step = 0; step < 64 && !script.done(); ++step) {
        switch (script.byte() % 5) {
            case 0: {
                const proto::ByteView piece = script.bytes(script.byte());
                sender->seal(std::span(&piece, 1), wire);
                sent_data.insert(sent_data.end(), piece.begin(), piece.end());
                break;
            }
            case 1: {
                const std::uint8_t type = script.byte();
                sender->seal_content(type, script.bytes(script.byte()), wire);
                wire_intact = false;  // the receiver may end the link on it
                break;
            }
            case 2: {
                const proto::ByteView raw = script.bytes(script.byte());
                std::copy(raw.begin(), raw.end(), wire.append(raw.size()));
                wire_intact = false;
                break;
            }
            case 3: {
                const std::size_t back = script.byte();
                const std::uint8_t flip = script.byte();
                if (back < wire.size() && flip != 0) {
                    wire.data()[wire.size() - 1 - back] ^= flip;
                    wire_intact = false;
                }
                break;
            }
            case 4:
                sender->request_key_update(wire);
                break;
        }
    }

    // Open every whole record, as ByteStream does: straight into a buffer of the record's size.
    proto::Bytes opened_data;
    std::size_t at = 0;
    bool ended = false;
    while (!ended) {
        const auto framing = net::TlsRecords::frame(proto::ByteView(wire.data() + at, wire.size() - at));
        if (framing.error) {
            ended = true;
            break;
        }
        if (framing.size == 0)
            break;
        PLEXUS_FUZZ_CHECK(framing.size <= net::TlsRecords::max_record && at + framing.size <= wire.size());
        const std::span record(wire.data() + at, framing.size);
        proto::Bytes out(framing.size - net::TlsRecords::header_size - net::TlsRecords::tag_size);
        const auto opened = receiver->open(record, out.data());
        at += framing.size;
        if (opened.error || opened.closed) {
            ended = true;
            break;
        }
        PLEXUS_FUZZ_CHECK(opened.plain <= net::TlsRecords::max_plain && opened.plain <= out.size());
        opened_data.insert(opened_data.end(), out.begin(),
                           out.begin() + static_cast<std::ptrdiff_t>(opened.plain));
        if (receiver->owes_key_update()) {
            net::RecordBuffer answer;
            receiver->answer_key_update(answer);
            PLEXUS_FUZZ_CHECK(!answer.empty());
        }
    }
    if (wire_intact) {
        // Nothing but seal()'s records and key updates: everything arrives, in order, and the
        // whole wire is read.
        PLEXUS_FUZZ_CHECK(!ended);
        PLEXUS_FUZZ_CHECK(at == wire.size());
        PLEXUS_FUZZ_CHECK(opened_data == sent_data);
    }
    return 0;
}
