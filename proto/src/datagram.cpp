#include "plexus/proto/datagram.hpp"

#include <algorithm>
#include <string>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {
constexpr std::uint8_t magic[4] = {'P', 'L', 'X', 'D'};
}

std::uint64_t fragment_count(std::uint64_t length, std::uint64_t fragment_size) {
    if (length == 0 || fragment_size == 0)
        return 1;
    return length / fragment_size + (length % fragment_size != 0 ? 1 : 0);
}

void append_datagram_header(Bytes& out, const DatagramHeader& header) {
    out.insert(out.end(), std::begin(magic), std::end(magic));
    out.push_back(datagram_version);
    out.push_back(header.sealed ? datagram_flag_sealed : 0);
    append_varint(out, header.stream);
    append_varint(out, header.message);
    append_varint(out, header.length);
    append_varint(out, header.fragment_size);
    append_varint(out, header.index);
}

Result<DatagramView> decode_datagram(ByteView datagram, std::uint64_t max_message) {
    FieldReader reader(datagram);
    const auto head = reader.raw("magic", 4);
    if (!head)
        return Error{reader.error()};
    if (!std::equal(head->begin(), head->end(), std::begin(magic)))
        return Error{"not a Plexus datagram (bad magic)"};
    const auto version = reader.byte("version");
    const auto flags = reader.byte("flags");
    if (!version || !flags)
        return Error{reader.error()};
    if (*version != datagram_version) {
        return Error{"datagram version " + std::to_string(*version) + ", expected " +
                     std::to_string(datagram_version)};
    }
    if ((*flags & ~datagram_flag_sealed) != 0)
        return Error{"unknown datagram flags " + std::to_string(*flags)};
    DatagramView view;
    auto& h = view.header;
    h.sealed = (*flags & datagram_flag_sealed) != 0;
    const auto stream = reader.varint("stream");
    const auto message = reader.varint("message");
    const auto length = reader.varint("length");
    const auto fragment_size = reader.varint("fragment_size");
    const auto index = reader.varint("index");
    if (!index)
        return Error{reader.error()};
    h.stream = *stream;
    h.message = *message;
    h.length = *length;
    h.fragment_size = *fragment_size;
    h.index = *index;
    if (h.length > max_message) {
        return Error{"message of " + std::to_string(h.length) + " bytes exceeds the limit " +
                     std::to_string(max_message)};
    }
    if (h.fragment_size == 0)
        return Error{"fragment_size 0"};
    const auto count = fragment_count(h.length, h.fragment_size);
    if (count > max_datagram_fragments) {
        return Error{"message cut into " + std::to_string(count) + " fragments, more than " +
                     std::to_string(max_datagram_fragments)};
    }
    if (h.index >= count) {
        return Error{"fragment " + std::to_string(h.index) + " of a " + std::to_string(count) +
                     "-fragment message"};
    }
    ByteView rest = reader.rest();
    view.head = datagram.first(datagram.size() - rest.size());
    if (h.sealed) {
        if (rest.size() < datagram_sealed_tag_size)
            return Error{"sealed datagram too short for its tag"};
        view.tag = rest.last(datagram_sealed_tag_size);
        rest = rest.first(rest.size() - datagram_sealed_tag_size);
    }
    const std::uint64_t begin = h.index * h.fragment_size;
    // index < count keeps begin within length; fragment_size may be any 64-bit number.
    const std::uint64_t expected = std::min(h.length - begin, h.fragment_size);
    if (rest.size() != expected) {
        return Error{"fragment " + std::to_string(h.index) + " holds " + std::to_string(rest.size()) +
                     " bytes, expected " + std::to_string(expected)};
    }
    view.fragment = rest;
    return view;
}

}  // namespace plexus::proto
