#pragma once
// The CLI's requests are the structs of plexus/proto/operations.hpp and name_operations.hpp; their
// answers are read through the reply structs, here.

#include "plexus/client.hpp"

namespace plexus::cli {

/// An ok answer read as `Answer` (a reply struct of plexus/proto/); an answer that does not decode
/// comes from something that is not the daemon or name server we speak to: refused (exit 4).
template <class Answer>
Answer read_as(const Value& body) {
    auto decoded = Answer::decode(body);
    if (!decoded)
        throw Error(ErrorCode::refused, decoded.error().message);
    return std::move(*decoded);
}

}  // namespace plexus::cli
