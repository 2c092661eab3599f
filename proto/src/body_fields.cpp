#include "body_fields.hpp"

namespace plexus::proto::body {

Reader::Reader(const nlohmann::json& body, std::string what) : body_(body), what_(std::move(what)) {
    if (!body_.is_object())
        error_ = "malformed " + what_ + ": not a map";
}

const nlohmann::json* Reader::find(const char* key) const {
    if (!body_.is_object())
        return nullptr;
    const auto it = body_.find(key);
    return it == body_.end() ? nullptr : &*it;
}

void Reader::wrong(const std::string& key, const char* must_be) {
    if (!error_)
        error_ = "malformed " + what_ + ": '" + key + "' must be " + must_be;
}

bool is_whole(const nlohmann::json& value) {
    return value.is_number_unsigned() || (value.is_number_integer() && value.get<std::int64_t>() >= 0);
}

void Reader::text(const char* key, std::string& out) {
    if (const auto* field = find(key)) {
        if (field->is_string())
            out = field->get<std::string>();
        else
            wrong(key, "text");
    }
}

void Reader::flag(const char* key, bool& out) {
    if (const auto* field = find(key)) {
        if (field->is_boolean())
            out = field->get<bool>();
        else
            wrong(key, "true or false");
    }
}

void Reader::whole(const char* key, std::uint64_t& out) {
    if (const auto* field = find(key)) {
        if (is_whole(*field))
            out = field->get<std::uint64_t>();
        else
            wrong(key, "a whole number of 0 or more");
    }
}

void Reader::whole(const char* key, std::optional<std::uint64_t>& out) {
    if (find(key)) {
        std::uint64_t value = 0;
        whole(key, value);
        out = value;
    }
}

void Reader::texts(const char* key, std::vector<std::string>& out) {
    if (const auto* field = find(key)) {
        if (!field->is_array())
            return wrong(key, "a list of texts");
        out.clear();
        for (const auto& entry : *field) {
            if (!entry.is_string())
                return wrong(key, "a list of texts");
            out.push_back(entry.get<std::string>());
        }
    }
}

void Reader::wholes(const char* key, std::vector<std::uint64_t>& out) {
    if (const auto* field = find(key)) {
        if (!field->is_array())
            return wrong(key, "a list of whole numbers");
        out.clear();
        for (const auto& entry : *field) {
            if (!is_whole(entry))
                return wrong(key, "a list of whole numbers");
            out.push_back(entry.get<std::uint64_t>());
        }
    }
}

void Reader::map(const char* key, nlohmann::json& out) {
    if (const auto* field = find(key)) {
        if (field->is_object())
            out = *field;
        else
            wrong(key, "a map");
    }
}

void Reader::list(const char* key, nlohmann::json& out) {
    if (const auto* field = find(key)) {
        if (field->is_array())
            out = *field;
        else
            wrong(key, "a list");
    }
}

std::string request_of(Op op) {
    return std::string(op_name(op)) + " request";
}

std::string reply_of(Op op) {
    return std::string(op_name(op)) + " reply";
}

}  // namespace plexus::proto::body
