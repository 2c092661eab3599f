#pragma once
// What the recording tests read out of a recording, through other ways than libplexus's: the MCAP
// library's reader for the decisions, Foxglove's @mcap/core under node for an independent check.

#include <openssl/evp.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/mcap/reader.hpp"
#include "plexus/mcap/recording_layout.hpp"

namespace plexus::test {

/// One recorded decision: what became of the k-th message of `source`.
struct RecordedDecision {
    std::string source;
    std::uint64_t seq = 0;
    std::string outcome;
    double decision_time = 0;
};

/// The decisions recorded for `port`, in file order.
inline std::vector<RecordedDecision> decisions_of(const std::string& file, const std::string& port) {
    auto reader = mcap::Reader::open(file);
    if (!reader)
        throw std::runtime_error(reader.error().message);
    std::set<std::uint16_t> channels;
    for (const auto& [id, channel] : reader->channels()) {
        if (channel.topic == mcap::layout::decisions_topic(port))
            channels.insert(id);
    }
    std::vector<RecordedDecision> out;
    auto read = reader->for_each_message(
        [&](const mcap::MessageView& view) {
            const auto entry = nlohmann::json::parse(view.data.begin(), view.data.end());
            out.push_back({entry["source"], entry["seq"], entry["outcome"], entry["decision_time"]});
            return true;
        },
        &channels);
    if (!read)
        throw std::runtime_error(read.error().message);
    return out;
}

inline std::string sha256_hex(const std::uint8_t* data, std::size_t size) {
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int length = 0;
    EVP_Digest(data, size, digest, &length, EVP_sha256(), nullptr);
    std::string hex;
    char two[3];
    for (unsigned int i = 0; i < length; ++i) {
        std::snprintf(two, sizeof two, "%02x", digest[i]);
        hex += two;
    }
    return hex;
}

/// Debian's node (or the one on PATH); "" when there is none.
inline std::string node_path() {
    for (const char* candidate : {"/usr/bin/node", "/usr/bin/nodejs", "/usr/local/bin/node"}) {
        if (::access(candidate, X_OK) == 0)
            return candidate;
    }
    return "";
}

}  // namespace plexus::test
