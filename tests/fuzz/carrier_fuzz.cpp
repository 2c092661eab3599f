// The carrier-string parser (carrier.hpp) and the endpoint parser (endpoint.hpp), user text both.
// Properties: when a carrier parses, its canonical text parses to the same carrier
// (parse(text(parse(x))) == parse(x)) and is its own canonical text; validating never fails in
// any other way than with a reason. When "HOST:PORT" parses, its text parses back the same.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_check.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/endpoint.hpp"

namespace proto = plexus::proto;

namespace {

bool same_carrier(const proto::Carrier& a, const proto::Carrier& b) {
    if (a.base != b.base || a.clauses.size() != b.clauses.size())
        return false;
    for (std::size_t i = 0; i < a.clauses.size(); ++i) {
        const auto& x = a.clauses[i];
        const auto& y = b.clauses[i];
        if (x.side != y.side || x.modifier != y.modifier || x.params.size() != y.params.size())
            return false;
        for (std::size_t k = 0; k < x.params.size(); ++k) {
            if (x.params[k].key != y.params[k].key || x.params[k].value != y.params[k].value)
                return false;
        }
    }
    return true;
}

void check_carrier(std::string_view text) {
    const auto carrier = proto::parse_carrier(text);
    if (!carrier) {
        PLEXUS_FUZZ_CHECK(!carrier.error().message.empty());
        return;
    }
    const auto canonical = carrier->text();
    const auto again = proto::parse_carrier(canonical);
    PLEXUS_FUZZ_CHECK(again.ok());
    PLEXUS_FUZZ_CHECK(same_carrier(*again, *carrier));
    PLEXUS_FUZZ_CHECK(again->text() == canonical);
    for (const auto& clause : carrier->clauses) {
        for (const auto& param : clause.params)
            PLEXUS_FUZZ_CHECK(clause.find(param.key) != nullptr);
    }
    const auto valid = proto::validate_carrier(*carrier);
    PLEXUS_FUZZ_CHECK(valid.ok() || !valid.error().message.empty());
}

void check_endpoint(std::string_view text) {
    const auto endpoint = proto::parse_endpoint(text);
    if (!endpoint)
        return;
    const auto again = proto::parse_endpoint(endpoint->text());
    PLEXUS_FUZZ_CHECK(again.ok() && again->host == endpoint->host && again->port == endpoint->port);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    check_carrier(text);
    check_endpoint(text);
    return 0;
}
