#pragma once
// Reading and writing the fields of a request or reply body for operations.cpp and
// name_operations.cpp: each read checks the field's type and the first wrong one is kept as the
// reason, so a decode function reads every field and asks for its result once.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/ops.hpp"

namespace plexus::proto::body {

/// Reads the fields of one body. A missing field (or a body that is not a map, which has none)
/// leaves the value as it was: its default.
class Reader {
public:
    /// `what` names the body in errors: "open request", "open reply".
    Reader(const nlohmann::json& body, std::string what);

    void text(const char* key, std::string& out);
    void flag(const char* key, bool& out);
    /// A whole number of 0 or more (CBOR's unsigned integers; a negative or fractional one is wrong).
    void whole(const char* key, std::uint64_t& out);
    void whole(const char* key, std::optional<std::uint64_t>& out);
    void texts(const char* key, std::vector<std::string>& out);
    void wholes(const char* key, std::vector<std::uint64_t>& out);
    /// A map, kept as it is.
    void map(const char* key, nlohmann::json& out);
    /// A list, kept as it is.
    void list(const char* key, nlohmann::json& out);
    /// The field when it is present, for reading entries of lists; null when absent.
    const nlohmann::json* find(const char* key) const;
    /// Records that `key` is not `must_be` (the first such failure is kept).
    void wrong(const std::string& key, const char* must_be);

    /// `value`, or the first reason a field was wrong.
    template <class T>
    Result<T> result(T value) const {
        if (error_)
            return Error{*error_};
        return value;
    }

private:
    const nlohmann::json& body_;
    std::string what_;
    std::optional<std::string> error_;
};

/// "open request", "lookup reply": how errors name a body.
std::string request_of(Op op);
std::string reply_of(Op op);

/// A whole number of 0 or more, as Reader::whole takes it.
bool is_whole(const nlohmann::json& value);

}  // namespace plexus::proto::body
