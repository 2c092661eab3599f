#include "expand.hpp"

#include <cctype>
#include <cstdlib>

namespace plexus::app {

namespace {

bool valid_name(std::string_view name) {
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front())))
        return false;
    for (const char c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_')
            return false;
    }
    return true;
}

}  // namespace

VariableLookup process_environment() {
    return [](const std::string& name) -> std::optional<std::string> {
        if (const char* value = std::getenv(name.c_str()))
            return std::string(value);
        return std::nullopt;
    };
}

proto::Result<std::string> expand_variables(std::string_view text, const VariableLookup& lookup) {
    std::string out;
    out.reserve(text.size());
    std::size_t i = 0;
    while (i < text.size()) {
        const char c = text[i];
        if (c != '$' || i + 1 >= text.size() || (text[i + 1] != '{' && text[i + 1] != '$')) {
            out += c;  // a lone `$` stays as written: "$5" is a price, not a variable
            ++i;
            continue;
        }
        if (text[i + 1] == '$') {
            out += '$';
            i += 2;
            continue;
        }
        const std::size_t close = text.find('}', i + 2);
        if (close == std::string_view::npos)
            return proto::Error{"'${' at position " + std::to_string(i) + " has no closing '}'"};
        const std::string_view inside = text.substr(i + 2, close - i - 2);
        const std::size_t dash = inside.find(":-");
        const std::string name(inside.substr(0, dash));
        if (!valid_name(name))
            return proto::Error{"'${" + std::string(inside) +
                                "}': a variable name is letters, digits and '_', not starting with a digit"};
        const auto value = lookup(name);
        if (dash != std::string_view::npos && (!value || value->empty())) {
            out += inside.substr(dash + 2);
        } else if (value) {
            out += *value;
        } else {
            return proto::Error{"variable " + name + " is not set (set it, or give a default: ${" + name +
                                ":-value})"};
        }
        i = close + 1;
    }
    return out;
}

}  // namespace plexus::app
