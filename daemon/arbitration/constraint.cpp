#include "constraint.hpp"

#include <algorithm>
#include <optional>

namespace plexus::daemon::arbitration {

struct Constraint::Node {
    enum class Kind { constant, event, negation, conjunction, disjunction };
    Kind kind = Kind::constant;
    bool value = false;  ///< for a constant
    std::string event;   ///< for an event
    std::shared_ptr<const Node> left;
    std::shared_ptr<const Node> right;
};

namespace {

using Node = Constraint::Node;
using NodePtr = std::shared_ptr<const Node>;

// The parser, the evaluation and the tree's destructor all recurse, and a constraint comes from a
// carrier string or a script: 100 000 nested '(' (or "not not ...", or a 1 000 000-term "and"
// chain) overflowed the daemon's stack and took it down. These limits bound the recursion
// depth; real constraints are a few names and a level or two of parentheses.
constexpr std::size_t max_length = 4096;  ///< bounds the length of and/or chains
constexpr std::size_t max_nesting = 64;   ///< levels of '(' and 'not'

struct Token {
    enum class Kind { name, open, close, end };
    Kind kind = Kind::end;
    std::string text;
    std::size_t position = 0;
};

bool is_name_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '.' || c == ':' || c == '/' || c == '-';
}

class Parser {
public:
    explicit Parser(std::string_view text) : text_(text) {}

    proto::Result<NodePtr> parse() {
        if (text_.size() > max_length)
            return proto::Error{"constraint of " + std::to_string(text_.size()) +
                                " characters: longer than the limit of " + std::to_string(max_length)};
        if (auto error = tokenize())
            return proto::Error{*error};
        auto root = expression();
        if (!root)
            return root;
        if (peek().kind != Token::Kind::end)
            return fail(peek(), "expected 'and', 'or' or the end");
        return root;
    }

private:
    std::optional<std::string> tokenize() {
        std::size_t i = 0;
        while (i < text_.size()) {
            const char c = text_[i];
            if (c == ' ' || c == '\t') {
                ++i;
            } else if (c == '(' || c == ')') {
                tokens_.push_back({c == '(' ? Token::Kind::open : Token::Kind::close, std::string(1, c), i});
                ++i;
            } else if (is_name_char(c)) {
                const std::size_t start = i;
                while (i < text_.size() && is_name_char(text_[i]))
                    ++i;
                tokens_.push_back({Token::Kind::name, std::string(text_.substr(start, i - start)), start});
            } else {
                return where(i) + ": unexpected character '" + std::string(1, c) + "'";
            }
        }
        tokens_.push_back({Token::Kind::end, "", text_.size()});
        return std::nullopt;
    }

    std::string where(std::size_t position) const {
        return "constraint '" + std::string(text_) + "' at position " + std::to_string(position);
    }
    proto::Error fail(const Token& token, const std::string& expected) const {
        const std::string found = token.kind == Token::Kind::end ? "the end" : "'" + token.text + "'";
        return proto::Error{where(token.position) + ": " + expected + ", found " + found};
    }

    static std::string too_deep() {
        return "expected at most " + std::to_string(max_nesting) + " nested '(' and 'not'";
    }

    const Token& peek() const { return tokens_[next_]; }
    bool is_keyword(const char* word) const {
        return peek().kind == Token::Kind::name && peek().text == word;
    }

    static NodePtr binary(Node::Kind kind, NodePtr left, NodePtr right) {
        auto node = std::make_shared<Node>();
        node->kind = kind;
        node->left = std::move(left);
        node->right = std::move(right);
        return node;
    }

    proto::Result<NodePtr> expression() {
        auto left = term();
        if (!left)
            return left;
        while (is_keyword("or")) {
            ++next_;
            auto right = term();
            if (!right)
                return right;
            left = binary(Node::Kind::disjunction, std::move(*left), std::move(*right));
        }
        return left;
    }

    proto::Result<NodePtr> term() {
        auto left = factor();
        if (!left)
            return left;
        while (is_keyword("and")) {
            ++next_;
            auto right = factor();
            if (!right)
                return right;
            left = binary(Node::Kind::conjunction, std::move(*left), std::move(*right));
        }
        return left;
    }

    proto::Result<NodePtr> factor() {
        const Token& token = peek();
        auto node = std::make_shared<Node>();
        switch (token.kind) {
            case Token::Kind::open: {
                if (++depth_ > max_nesting)
                    return fail(token, too_deep());
                ++next_;
                auto inner = expression();
                if (!inner)
                    return inner;
                if (peek().kind != Token::Kind::close)
                    return fail(peek(), "expected ')' to close the '(' at position " +
                                            std::to_string(token.position));
                ++next_;
                --depth_;
                return inner;
            }
            case Token::Kind::name:
                if (token.text == "and" || token.text == "or")
                    return fail(token, "expected an event name, 'not', 'true', 'false' or '('");
                if (token.text == "not" && ++depth_ > max_nesting)
                    return fail(token, too_deep());
                ++next_;
                if (token.text == "not") {
                    auto operand = factor();
                    if (!operand)
                        return operand;
                    --depth_;
                    node->kind = Node::Kind::negation;
                    node->left = std::move(*operand);
                } else if (token.text == "true" || token.text == "false") {
                    node->kind = Node::Kind::constant;
                    node->value = token.text == "true";
                } else {
                    node->kind = Node::Kind::event;
                    node->event = token.text;
                }
                return NodePtr(std::move(node));
            case Token::Kind::close:
            case Token::Kind::end:
                break;
        }
        return fail(token, "expected an event name, 'not', 'true', 'false' or '('");
    }

    std::string_view text_;
    std::vector<Token> tokens_;
    std::size_t next_ = 0;
    std::size_t depth_ = 0;  ///< '(' and 'not' being parsed around the current token
};

template <typename HasEvent>
bool evaluate_node(const Node& node, const HasEvent& has_event) {
    switch (node.kind) {
        case Node::Kind::constant:
            return node.value;
        case Node::Kind::event:
            return has_event(node.event);
        case Node::Kind::negation:
            return !evaluate_node(*node.left, has_event);
        case Node::Kind::conjunction:
            return evaluate_node(*node.left, has_event) && evaluate_node(*node.right, has_event);
        case Node::Kind::disjunction:
            return evaluate_node(*node.left, has_event) || evaluate_node(*node.right, has_event);
    }
    return false;
}

void collect_events(const Node& node, std::vector<std::string>& events) {
    if (node.kind == Node::Kind::event)
        events.push_back(node.event);
    if (node.left)
        collect_events(*node.left, events);
    if (node.right)
        collect_events(*node.right, events);
}

}  // namespace

proto::Result<Constraint> Constraint::parse(std::string_view text) {
    auto root = Parser(text).parse();
    if (!root)
        return root.error();
    Constraint constraint;
    constraint.text_ = std::string(text);
    constraint.root_ = std::move(*root);
    collect_events(*constraint.root_, constraint.events_);
    std::sort(constraint.events_.begin(), constraint.events_.end());
    constraint.events_.erase(std::unique(constraint.events_.begin(), constraint.events_.end()),
                             constraint.events_.end());
    return constraint;
}

bool Constraint::evaluate(const std::function<bool(const std::string&)>& has_event) const {
    return evaluate_node(*root_, has_event);
}

bool Constraint::evaluate(const std::set<std::string>& present) const {
    return evaluate_node(*root_, [&](const std::string& name) { return present.count(name) > 0; });
}

}  // namespace plexus::daemon::arbitration
