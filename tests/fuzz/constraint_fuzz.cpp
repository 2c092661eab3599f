// The constraint parser and evaluator (daemon/arbitration/constraint.hpp) against a reference
// written here from the same grammar, independently of it: a tokenizer and a recursive-descent
// evaluator that computes the value straight from the tokens, building no tree.
// Properties: both accept the same texts (with the same limits on length and nesting); both find
// the same events; and for every assignment of those events (all 2^n of them up to 10 events, a
// few otherwise) both give the same value, through either evaluate() overload.
#include <algorithm>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "arbitration/constraint.hpp"
#include "fuzz_check.hpp"

using plexus::daemon::arbitration::Constraint;

namespace {

// The limits constraint.cpp documents: a longer text, or more nested '(' and 'not', is refused.
constexpr std::size_t max_length = 4096;
constexpr int max_nesting = 64;

bool name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 ||
           std::string_view("_.:/-").find(c) != std::string_view::npos;
}

/// Tokens: "(", ")" and names (keywords included); nullopt on any other character.
std::optional<std::vector<std::string>> tokens_of(std::string_view text) {
    std::vector<std::string> tokens;
    for (std::size_t i = 0; i < text.size();) {
        if (text[i] == ' ' || text[i] == '\t') {
            ++i;
        } else if (text[i] == '(' || text[i] == ')') {
            tokens.emplace_back(1, text[i++]);
        } else if (name_char(text[i])) {
            std::size_t end = i;
            while (end < text.size() && name_char(text[end]))
                ++end;
            tokens.emplace_back(text.substr(i, end - i));
            i = end;
        } else {
            return std::nullopt;
        }
    }
    return tokens;
}

/// Evaluates the tokens under one assignment; `ok` turns false on a syntax error.
class Reference {
public:
    Reference(const std::vector<std::string>& tokens, const std::set<std::string>& present)
        : tokens_(tokens), present_(present) {}

    /// The value, or nullopt when the tokens are not a constraint.
    std::optional<bool> run() {
        const bool value = expr();
        if (!ok_ || at_ != tokens_.size())
            return std::nullopt;
        return value;
    }
    const std::set<std::string>& names() const { return names_; }

private:
    const std::string* peek() const { return at_ < tokens_.size() ? &tokens_[at_] : nullptr; }
    bool next_is(const char* word) const { return peek() && *peek() == word; }

    bool expr() {
        bool value = term();
        while (ok_ && next_is("or")) {
            ++at_;
            const bool right = term();
            value = value || right;
        }
        return value;
    }
    bool term() {
        bool value = factor();
        while (ok_ && next_is("and")) {
            ++at_;
            const bool right = factor();
            value = value && right;
        }
        return value;
    }
    bool factor() {
        const std::string* token = peek();
        if (!ok_ || !token || *token == ")" || *token == "and" || *token == "or")
            return ok_ = false;
        ++at_;
        if (*token == "(" || *token == "not") {
            if (++depth_ > max_nesting)
                return ok_ = false;
            bool value = false;
            if (*token == "not") {
                value = !factor();
            } else {
                value = expr();
                if (!next_is(")"))
                    return ok_ = false;
                ++at_;
            }
            --depth_;
            return value;
        }
        if (*token == "true")
            return true;
        if (*token == "false")
            return false;
        names_.insert(*token);
        return present_.count(*token) > 0;
    }

    const std::vector<std::string>& tokens_;
    const std::set<std::string>& present_;
    std::set<std::string> names_;
    std::size_t at_ = 0;
    int depth_ = 0;
    bool ok_ = true;
};

/// The reference's value under `present`, with the names it saw.
std::optional<bool> reference_value(std::string_view text, const std::set<std::string>& present,
                                    std::set<std::string>* names = nullptr) {
    if (text.size() > max_length)
        return std::nullopt;
    const auto tokens = tokens_of(text);
    if (!tokens)
        return std::nullopt;
    Reference reference(*tokens, present);
    const auto value = reference.run();
    if (names)
        *names = reference.names();
    return value;
}

void check_assignment(const Constraint& constraint, std::string_view text,
                      const std::set<std::string>& present) {
    const auto expected = reference_value(text, present);
    PLEXUS_FUZZ_CHECK(expected.has_value());
    PLEXUS_FUZZ_CHECK(constraint.evaluate(present) == *expected);
    PLEXUS_FUZZ_CHECK(constraint.evaluate([&](const std::string& name) { return present.count(name) > 0; }) ==
                      *expected);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const auto constraint = Constraint::parse(text);
    std::set<std::string> names;
    const auto reference = reference_value(text, {}, &names);
    PLEXUS_FUZZ_CHECK(constraint.ok() == reference.has_value());
    if (!constraint) {
        PLEXUS_FUZZ_CHECK(!constraint.error().message.empty());
        return 0;
    }
    PLEXUS_FUZZ_CHECK(constraint->text() == text);
    const auto& events = constraint->events();
    PLEXUS_FUZZ_CHECK(std::vector<std::string>(names.begin(), names.end()) == events);
    if (events.size() <= 10) {
        for (std::uint32_t mask = 0; mask < (1u << events.size()); ++mask) {
            std::set<std::string> present;
            for (std::size_t i = 0; i < events.size(); ++i) {
                if (mask & (1u << i))
                    present.insert(events[i]);
            }
            check_assignment(*constraint, text, present);
        }
        return 0;
    }
    // Too many events to try every assignment: none, all, and two alternating ones.
    for (int pattern = 0; pattern < 4; ++pattern) {
        std::set<std::string> present;
        for (std::size_t i = 0; i < events.size(); ++i) {
            if (pattern == 1 || (pattern == 2 && i % 2 == 0) || (pattern == 3 && i % 2 == 1))
                present.insert(events[i]);
        }
        check_assignment(*constraint, text, present);
    }
    return 0;
}
