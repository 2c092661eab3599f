#pragma once
// Finding the name server (DESIGN.md, "Several machines"): the order in which programs look, and
// the multicast query the name server answers. Both ends share this header so they agree; the
// sockets are the programs' own business.
//
// Query: one datagram to the discovery group holding a request frame {"op": "discover", "nonce":
// N}, N fresh random hex for each query. The name server answers the sender directly (unicast)
// with a reply frame {"names": "HOST:PORT"}; HOST is 0.0.0.0 when the name server listens on every
// address, and the asker then uses the address the answer came from. A name server with the
// deployment secret adds "proof": Secret::discovery_proof(N, "HOST:PORT"); an asker with the
// secret takes only answers with a good proof, and waits on for one past any other (a rogue name
// server, or a forged answer, cannot win the race).

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "plexus/proto/auth.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/endpoint.hpp"

namespace plexus::proto {

/// The discovery group and port, unless PLEXUS_DISCOVERY says otherwise ("GROUP:PORT" or "off").
inline constexpr const char* default_discovery_group = "239.255.80.88:10101";
/// Hops a query may travel: 1, the local network only.
inline constexpr int default_discovery_ttl = 1;

enum class NamesSource { flag, environment, config, discovery, fallback };

/// The address a program will use for the name server, and how it was found.
struct NamesChoice {
    std::string address;
    NamesSource source = NamesSource::fallback;
    std::string detail;  ///< e.g. the config file's path, or the discovery group
    /// How it was found: "from PLEXUS_NAMES", "found by multicast discovery on GROUP:PORT", ...
    std::string how() const;
};

/// The discovery group from PLEXUS_DISCOVERY; nullopt when it is "off". Malformed text is an Error.
Result<std::optional<Endpoint>> discovery_group();

/// The config file programs read the name server's address from (key "names"): $PLEXUS_CONFIG,
/// else $XDG_CONFIG_HOME/plexus/config.json (~/.config/plexus/config.json), else
/// /etc/plexus/config.json: the first that exists. Empty when none does.
std::string default_config_file();
/// The "names" value of a JSON config file; nullopt when the file or the key is missing. An
/// Error when the file cannot be parsed.
Result<std::optional<std::string>> names_in_config(const std::string& path);

/// Chooses in the contract's order: `flag` (--names, when given), $PLEXUS_NAMES, the config file,
/// `discover()` (called only when none of those gave an address), 127.0.0.1:10100.
/// `config_file` may be empty (then default_config_file() is looked at).
Result<NamesChoice> choose_names(const std::optional<std::string>& flag, const std::string& config_file,
                                 const std::function<std::optional<std::string>()>& discover);

/// A fresh nonce for a query: 32 random hex digits.
std::string discovery_nonce();
/// The query datagram (`nonce` may be empty: an answer then cannot carry a proof).
Bytes discovery_query(const std::string& nonce = {});
/// What an answer datagram says.
struct DiscoveryAnswer {
    std::string names;    ///< the name server's address, HOST filled in from `from` when it was 0.0.0.0
    bool proven = false;  ///< it carries a good proof over the query's nonce (only with a secret)
};
/// The answer in a datagram; `from` is the address the answer came from, used when the name server
/// listens on every address. With `secret`, `proven` says whether its proof over `nonce` is good.
/// nullopt when the datagram is not an answer.
std::optional<DiscoveryAnswer> discovery_answer(ByteView datagram, const std::string& from,
                                                const Secret* secret = nullptr,
                                                const std::string& nonce = {});
/// The answer the name server sends for its listening endpoint to a query with `nonce`, with a
/// proof when it has `secret` and the query a nonce.
Bytes discovery_reply(std::uint64_t id, const Endpoint& names, const Secret* secret = nullptr,
                      const std::string& nonce = {});

}  // namespace plexus::proto

namespace plexus::proto {

/// What a discovery query found.
struct DiscoveryResult {
    std::optional<std::string> names;  ///< the first answer taken
    std::vector<std::string> ignored;  ///< with a secret: who answered without a good proof
};

/// Sends the discovery query to `group` and waits up to `timeout` for an answer (three tries);
/// with `secret`, for an answer that proves the name server holds it, ignoring any other.
/// Blocking, with plain sockets: the one piece of I/O in proto/, because the daemon, the client
/// library and the CLI all need it and proto/ is the only library they share.
DiscoveryResult query_discovery(const Endpoint& group, std::chrono::milliseconds timeout,
                                int ttl = default_discovery_ttl, const Secret* secret = nullptr);

/// choose_names with the real query: what plexusd, plexus and libplexus call. With `secret`,
/// discovery takes only a name server that proves it holds it; answers it ignored are named in
/// the choice's detail.
Result<NamesChoice> find_names(const std::optional<std::string>& flag, const std::string& config_file = {},
                               std::chrono::milliseconds timeout = std::chrono::milliseconds(600),
                               const Secret* secret = nullptr);

}  // namespace plexus::proto
