// Ray path criteria: parser, name resolution, the streaming evaluator and the direct oracle.
// The grammar and the semantics implemented here are written down in docs/criteria.md.

#include "analysis/criteria/criteria.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <limits>
#include <sstream>

#include "lensdata/toml_document.h"
#include "tracer/records/path_history.h"

namespace veil {

// Leaf Keywords
namespace {

constexpr std::array<std::string_view, kLeafKindCount> kLeafNames = {
    "emit", "hit",     "detector", "property",        "medium",           "reflect", "fresnel",
    "tir",  "refract", "scatter",  "scatter_reflect", "scatter_transmit", "absorb",  "exit"};

uint16_t bit(EventType t) { return static_cast<uint16_t>(1u << static_cast<unsigned>(t)); }

// Event types a leaf of kind k can match (before its object test).
uint16_t typeMaskOf(LeafKind k) {
    const uint16_t all = static_cast<uint16_t>((1u << kEventTypeCount) - 1);
    switch (k) {
        case LeafKind::Emit:
            return bit(EventType::Emit);
        case LeafKind::Hit:
        case LeafKind::Property:
        case LeafKind::Medium:
            return static_cast<uint16_t>(all & ~bit(EventType::Emit));
        case LeafKind::Detector:
            return bit(EventType::DetectorHit);
        case LeafKind::Reflect:
            return bit(EventType::SpecularReflect) | bit(EventType::FresnelReflect);
        case LeafKind::Fresnel:
            return bit(EventType::FresnelReflect);
        case LeafKind::Tir:
            return bit(EventType::TotalInternalReflection);
        case LeafKind::Refract:
            return bit(EventType::Refract);
        case LeafKind::Scatter:
            return bit(EventType::ScatterReflect) | bit(EventType::ScatterTransmit);
        case LeafKind::ScatterReflect:
            return bit(EventType::ScatterReflect);
        case LeafKind::ScatterTransmit:
            return bit(EventType::ScatterTransmit);
        case LeafKind::Absorb:
            return bit(EventType::SurfaceAbsorb) | bit(EventType::VolumeAbsorb);
        case LeafKind::Exit:
            return bit(EventType::Exit);
    }
    return 0;
}

}  // namespace

std::string_view toString(LeafKind k) { return kLeafNames[static_cast<size_t>(k)]; }
std::ostream& operator<<(std::ostream& os, LeafKind k) { return os << toString(k); }

std::ostream& operator<<(std::ostream& os, const CountRange& c) {
    if (c.min == 1 && c.max == CountRange::kUnbounded) return os;
    os << "{";
    if (c.min == c.max) return os << c.min << "}";
    if (c.min != 0) os << c.min;
    os << ",";
    if (c.max != CountRange::kUnbounded) os << c.max;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, CriterionState s) {
    switch (s) {
        case CriterionState::Undefined:
            return os << "undefined";
        case CriterionState::True:
            return os << "true";
        case CriterionState::False:
            return os << "false";
    }
    return os;
}

// Criterion Printing
size_t Criterion::nodeCount() const {
    size_t n = 1;
    for (const Criterion& c : children) n += c.nodeCount();
    return n;
}

std::ostream& operator<<(std::ostream& os, const Criterion& c) {
    using K = Criterion::Kind;
    switch (c.kind) {
        case K::Leaf:
            os << c.leaf;
            if (!c.patterns.empty()) {
                os << "(";
                for (size_t i = 0; i < c.patterns.size(); ++i)
                    os << (i ? " | " : "") << c.patterns[i].text;
                os << ")";
            }
            return os << c.count;
        case K::Not:
            return os << "not (" << c.children[0] << ")";
        case K::Seq:
            os << "seq(";
            for (size_t i = 0; i < c.children.size(); ++i) os << (i ? ", " : "") << c.children[i];
            return os << ")";
        case K::And:
        case K::Or:
            os << "(";
            for (size_t i = 0; i < c.children.size(); ++i)
                os << (i ? (c.kind == K::And ? " and " : " or ") : "") << c.children[i];
            return os << ")";
    }
    return os;
}

std::string toString(const Criterion& c) {
    std::ostringstream os;
    os << c;
    return os.str();
}

// Text Parser
namespace {

bool isIdentChar(char ch) { return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_'; }
bool isPatternChar(char ch) {
    return !std::isspace(static_cast<unsigned char>(ch)) && ch != '(' && ch != ')' && ch != '|' &&
           ch != ',' && ch != '{' && ch != '}' && ch != '\0';
}

// Groups, seq(...) and not nest by recursion, in the parsers and in everything that walks
// the tree: one level more while alive, bounded so that no text can exhaust the stack.
template <typename Parser>
class Nesting {
  public:
    // `at`: where the level opens in the text (the error points there).
    Nesting(Parser& p, size_t at) : p_(p) {
        if (++p_.depth_ > kMaxCriterionNesting)
            p_.fail("the criterion nests groups" + std::string(Parser::kNestingWhat) +
                        " deeper than " + std::to_string(kMaxCriterionNesting) + " levels",
                    at);
    }
    ~Nesting() { --p_.depth_; }
    Nesting(const Nesting&) = delete;
    Nesting& operator=(const Nesting&) = delete;

  private:
    Parser& p_;
};

class TextParser {
    friend class Nesting<TextParser>;
    static constexpr const char* kNestingWhat = ", seq(...) and not";

  public:
    TextParser(std::string_view text, std::string_view source) : text_(text), source_(source) {}

    Criterion parse() {
        Criterion c = parseOr();
        skipSpace();
        if (pos_ < text_.size()) fail("expected 'and', 'or' or the end of the criterion");
        return c;
    }

  private:
    [[noreturn]] void fail(const std::string& message, size_t at) const {
        throw ParseError(FileLoc{std::string(source_), 1, static_cast<int>(at) + 1}, message);
    }
    [[noreturn]] void fail(const std::string& message) const { fail(message, pos_); }

    void skipSpace() {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    }
    char peek() {
        skipSpace();
        return pos_ < text_.size() ? text_[pos_] : '\0';
    }
    void expect(char ch, const char* what) {
        if (peek() != ch) fail(std::string("expected ") + what);
        ++pos_;
    }
    // The identifier at pos_ (after spaces), not consumed.
    std::string_view peekWord() {
        skipSpace();
        size_t end = pos_;
        while (end < text_.size() && isIdentChar(text_[end])) ++end;
        return text_.substr(pos_, end - pos_);
    }
    bool acceptKeyword(std::string_view kw) {
        if (peekWord() != kw) return false;
        pos_ += kw.size();
        return true;
    }

    Criterion parseOr() { return parseList(Criterion::Kind::Or, "or"); }
    Criterion parseAnd() { return parseList(Criterion::Kind::And, "and"); }
    Criterion parseList(Criterion::Kind kind, std::string_view kw) {
        skipSpace();
        const int column = static_cast<int>(pos_) + 1;
        Criterion first = kind == Criterion::Kind::Or ? parseAnd() : parseUnary();
        if (peekWord() != kw) return first;
        Criterion node;
        node.kind = kind;
        node.column = column;
        node.children.push_back(std::move(first));
        while (acceptKeyword(kw))
            node.children.push_back(kind == Criterion::Kind::Or ? parseAnd() : parseUnary());
        return node;
    }
    Criterion parseUnary() {
        skipSpace();
        const int column = static_cast<int>(pos_) + 1;
        if (acceptKeyword("not")) {
            const Nesting<TextParser> nesting(*this, static_cast<size_t>(column) - 1);
            Criterion node;
            node.kind = Criterion::Kind::Not;
            node.column = column;
            node.children.push_back(parseUnary());
            return node;
        }
        return parsePrimary();
    }
    Criterion parsePrimary() {
        const char ch = peek();
        const size_t start = pos_;
        if (ch == '(') {
            const Nesting<TextParser> nesting(*this, pos_);
            ++pos_;
            Criterion inner = parseOr();
            expect(')', "')'");
            if (peek() == '{') fail("a count {..} applies to a leaf only, not to a group");
            return inner;
        }
        const std::string_view word = peekWord();
        if (word.empty()) {
            fail(ch == '\0' ? "expected a criterion (a leaf such as hit(sensor), seq(...), not "
                              "or '('), found the end"
                            : "expected a criterion (a leaf such as hit(sensor), seq(...), not "
                              "or '(')");
        }
        pos_ += word.size();
        if (word == "seq") {
            const Nesting<TextParser> nesting(*this, start);
            Criterion node;
            node.kind = Criterion::Kind::Seq;
            node.column = static_cast<int>(start) + 1;
            expect('(', "'(' after seq");
            node.children.push_back(parseOr());
            while (peek() == ',') {
                ++pos_;
                node.children.push_back(parseOr());
            }
            expect(')', "',' or ')' in seq(...)");
            if (peek() == '{') fail("a count {..} applies to a leaf only, not to seq");
            return node;
        }
        const auto it = std::find(kLeafNames.begin(), kLeafNames.end(), word);
        if (it == kLeafNames.end()) {
            std::string names;
            for (std::string_view n : kLeafNames) {
                if (!names.empty()) names += ", ";
                names += n;
            }
            std::vector<std::string> all{"seq", "not"};
            for (std::string_view n : kLeafNames) all.emplace_back(n);
            const std::string guess = closestSpelling(word, all);
            fail("unknown criterion '" + std::string(word) + "'" +
                     (guess.empty() ? "" : " (did you mean '" + guess + "'?)") +
                     "; expected seq, not or a leaf (" + names + ")",
                 start);
        }
        Criterion leaf;
        leaf.kind = Criterion::Kind::Leaf;
        leaf.leaf = static_cast<LeafKind>(it - kLeafNames.begin());
        leaf.column = static_cast<int>(start) + 1;
        if (peek() == '(') {
            ++pos_;
            if (peek() != ')') {
                for (;;) {
                    skipSpace();
                    const size_t ps = pos_;
                    while (pos_ < text_.size() && isPatternChar(text_[pos_])) ++pos_;
                    if (pos_ == ps) fail("expected an object pattern");
                    leaf.patterns.push_back(
                        {std::string(text_.substr(ps, pos_ - ps)), static_cast<int>(ps) + 1});
                    const char next = peek();
                    if (next == '|') {
                        ++pos_;
                        continue;
                    }
                    if (next == ')') break;
                    fail("expected '|' or ')' after a pattern");
                }
            }
            ++pos_;  // ')'
        }
        if (peek() == '{') leaf.count = parseCount();
        return leaf;
    }
    // Reads an unsigned number at pos_ (after spaces); -1 if there is none.
    int parseNumber() {
        skipSpace();
        const size_t s = pos_;
        long v = 0;
        while (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
            v = v * 10 + (text_[pos_] - '0');
            if (v > 1000000) fail("count too large", s);
            ++pos_;
        }
        return pos_ == s ? -1 : static_cast<int>(v);
    }
    CountRange parseCount() {
        const size_t open = pos_;
        ++pos_;  // '{'
        CountRange r;
        const int a = parseNumber();
        if (peek() == '}') {
            if (a < 0) fail("expected a number in the count");
            ++pos_;
            return {a, a};
        }
        if (peek() != ',') fail(a < 0 ? "expected a number in the count" : "expected ',' or '}'");
        ++pos_;
        const int b = parseNumber();
        if (a < 0 && b < 0) fail("expected a number in the count");
        expect('}', "'}'");
        r.min = a < 0 ? 0 : a;
        r.max = b < 0 ? CountRange::kUnbounded : b;
        if (r.min > r.max) fail("empty count range (min > max)", open);
        if (r.min == 0 && r.max == CountRange::kUnbounded)
            fail("count {0,} always holds; drop the leaf", open);
        return r;
    }

    std::string_view text_, source_;
    size_t pos_ = 0;
    int depth_ = 0;  // groups, seq(...) and not open at pos_
};

// OpticStudio Filter Parser
// or := and ('|' and)* ; and := unary ('&' unary)* ; unary := '!' unary | primary ;
// primary := '(' or ')' | ('H'|'R'|'T'|'S') number
class ZemaxParser {
    friend class Nesting<ZemaxParser>;
    static constexpr const char* kNestingWhat = " and '!'";

  public:
    ZemaxParser(std::string_view text, std::string_view source) : text_(text), source_(source) {}
    Criterion parse() {
        Criterion c = parseBinary(Criterion::Kind::Or, '|');
        if (peek() != '\0') fail("expected '&', '|' or the end of the filter");
        return c;
    }

  private:
    [[noreturn]] void fail(const std::string& message, size_t at) const {
        throw ParseError(FileLoc{std::string(source_), 1, static_cast<int>(at) + 1}, message);
    }
    [[noreturn]] void fail(const std::string& message) const { fail(message, pos_); }
    char peek() {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
        return pos_ < text_.size() ? text_[pos_] : '\0';
    }
    Criterion parseBinary(Criterion::Kind kind, char op) {
        const int column = static_cast<int>(pos_) + 1;
        auto sub = [&] {
            return kind == Criterion::Kind::Or ? parseBinary(Criterion::Kind::And, '&')
                                               : parseUnary();
        };
        Criterion first = sub();
        if (peek() != op) return first;
        Criterion node;
        node.kind = kind;
        node.column = column;
        node.children.push_back(std::move(first));
        while (peek() == op) {
            ++pos_;
            node.children.push_back(sub());
        }
        return node;
    }
    Criterion parseUnary() {
        const char ch = peek();
        if (ch == '!') {
            const Nesting<ZemaxParser> nesting(*this, pos_);
            Criterion node;
            node.kind = Criterion::Kind::Not;
            node.column = static_cast<int>(pos_) + 1;
            ++pos_;
            node.children.push_back(parseUnary());
            return node;
        }
        if (ch == '(') {
            const Nesting<ZemaxParser> nesting(*this, pos_);
            ++pos_;
            Criterion inner = parseBinary(Criterion::Kind::Or, '|');
            if (peek() != ')') fail("expected ')'");
            ++pos_;
            return inner;
        }
        const char up = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
        LeafKind kind;
        switch (up) {
            case 'H':
                kind = LeafKind::Hit;
                break;
            case 'R':
                kind = LeafKind::Reflect;
                break;
            case 'T':
                kind = LeafKind::Refract;
                break;
            case 'S':
                kind = LeafKind::Scatter;
                break;
            default:
                fail(ch == '\0' ? "expected Hn, Rn, Tn, Sn, '!' or '(', found the end"
                                : "expected Hn, Rn, Tn, Sn, '!' or '('");
        }
        Criterion leaf;
        leaf.kind = Criterion::Kind::Leaf;
        leaf.leaf = kind;
        leaf.column = static_cast<int>(pos_) + 1;
        ++pos_;
        const size_t s = pos_;
        while (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) ++pos_;
        if (pos_ == s || pos_ - s > 9) fail("expected an object number");
        leaf.patterns.push_back({std::string("#").append(text_.substr(s, pos_ - s)), leaf.column});
        return leaf;
    }

    std::string_view text_, source_;
    size_t pos_ = 0;
    int depth_ = 0;  // groups and '!' open at pos_
};

}  // namespace

Criterion parseCriterion(std::string_view text, std::string_view source) {
    return TextParser(text, source).parse();
}

Criterion parseZemaxFilter(std::string_view text, std::string_view source) {
    return ZemaxParser(text, source).parse();
}

// Name Resolution
bool CompiledCriterion::Leaf::matches(const PathEvent& e) const {
    if (!((typeMask >> static_cast<unsigned>(e.type)) & 1u)) return false;
    int64_t id = e.object;
    if (useMedium) {
        if (e.mediumBefore == e.mediumAfter) return false;
        id = e.mediumAfter;
    }
    if (anyObject) return true;
    if (id < 0 || static_cast<size_t>(id) >= set.size() * 64) return false;
    return (set[static_cast<size_t>(id) / 64] >> (id % 64)) & 1u;
}

namespace {

struct Compiler {
    const NameTable& names;
    std::string_view source;
    CompiledCriterion out;

    [[noreturn]] void fail(const NamePattern& p, const std::string& message) const {
        throw ParseError(FileLoc{std::string(source), 1, p.column}, message);
    }

    int32_t add(const Criterion& c, int32_t parent, int32_t indexInParent) {
        const int32_t id = static_cast<int32_t>(out.nodes.size());
        out.nodes.push_back({});
        out.nodes[id].kind = c.kind;
        out.nodes[id].parent = parent;
        out.nodes[id].indexInParent = indexInParent;
        if (c.kind == Criterion::Kind::Leaf) {
            out.nodes[id].leaf = static_cast<int32_t>(out.leaves.size());
            out.leaves.push_back(compileLeaf(c, id));
            return id;
        }
        if (c.children.empty() || (c.kind == Criterion::Kind::Not && c.children.size() != 1))
            throw ParseError(FileLoc{std::string(source), 1, c.column},
                             "malformed criterion node (wrong number of children)");
        std::vector<int32_t> kids;
        for (size_t i = 0; i < c.children.size(); ++i)
            kids.push_back(add(c.children[i], id, static_cast<int32_t>(i)));
        out.nodes[id].children = std::move(kids);
        return id;
    }

    CompiledCriterion::Leaf compileLeaf(const Criterion& c, int32_t node) {
        CompiledCriterion::Leaf leaf;
        leaf.node = node;
        leaf.typeMask = typeMaskOf(c.leaf);
        leaf.count = c.count;
        leaf.useMedium = c.leaf == LeafKind::Medium;
        if (c.count.min < 0 || c.count.min > c.count.max ||
            (c.count.min == 0 && c.count.max == CountRange::kUnbounded))
            throw ParseError(FileLoc{std::string(source), 1, c.column}, "invalid count range");
        const bool resolveAlways = c.leaf == LeafKind::Property || c.leaf == LeafKind::Detector;
        const bool any =
            c.patterns.empty() || std::any_of(c.patterns.begin(), c.patterns.end(),
                                              [](const NamePattern& p) { return p.text == "*"; });
        if (any && !resolveAlways) {
            leaf.anyObject = true;
            return leaf;
        }
        std::vector<NamePattern> patterns = c.patterns;
        if (patterns.empty()) patterns.push_back({"*", c.column});
        // The universe of names the patterns choose from.
        size_t size = 0;
        std::string what = "object";
        std::vector<std::vector<std::string_view>> candidates;
        if (c.leaf == LeafKind::Emit) {
            what = "source";
            for (const std::string& s : names.sources) candidates.push_back({s});
        } else if (c.leaf == LeafKind::Medium) {
            what = "medium";
            for (const std::string& m : names.media) candidates.push_back({m});
        } else {
            if (c.leaf == LeafKind::Property) what = "property";
            if (c.leaf == LeafKind::Detector) what = "detector";
            for (const NameTable::Object& o : names.objects) {
                std::vector<std::string_view> n;
                if (c.leaf == LeafKind::Property) {
                    if (!o.property.empty()) n.push_back(o.property);
                } else if (c.leaf != LeafKind::Detector || o.detector) {
                    n.push_back(o.name);
                    for (const std::string& a : o.aliases) n.push_back(a);
                }
                candidates.push_back(std::move(n));
            }
        }
        size = candidates.size();
        leaf.set.assign((size + 63) / 64, 0);
        for (const NamePattern& p : patterns) {
            bool found = false;
            auto set = [&](size_t i) {
                leaf.set[i / 64] |= uint64_t{1} << (i % 64);
                found = true;
            };
            if (p.text.size() > 1 && p.text[0] == '#' &&
                std::all_of(p.text.begin() + 1, p.text.end(),
                            [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)); })) {
                // An id too large for size_t matches nothing, as any id past the last.
                size_t id = std::numeric_limits<size_t>::max();
                std::from_chars(p.text.data() + 1, p.text.data() + p.text.size(), id);
                if (id < size && (c.leaf != LeafKind::Detector || !candidates[id].empty())) set(id);
            } else {
                for (size_t i = 0; i < size; ++i)
                    for (std::string_view n : candidates[i])
                        if (globMatch(p.text, n)) {
                            set(i);
                            break;
                        }
            }
            if (!found) {
                // Name what there is to choose from.
                std::string known;
                size_t listed = 0, total = 0;
                std::vector<std::string> every;
                for (const auto& choices : candidates) {
                    if (choices.empty()) continue;
                    for (std::string_view n : choices) every.emplace_back(n);
                    ++total;
                    if (listed < 40) {
                        known += (listed ? ", " : "") + std::string(choices.front());
                        ++listed;
                    }
                }
                if (total > listed) known += ", ... (" + std::to_string(total) + " in all)";
                const std::string guess = closestSpelling(p.text, every);
                fail(p,
                     what + " pattern '" + p.text + "' matches no " + what +
                         (guess.empty() ? "" : " (did you mean '" + guess + "'?)") +
                         (total ? "; the scene's " + what + (total == 1 ? " is " : "s are ") + known
                                : "; the scene has none"));
            }
        }
        return leaf;
    }
};

}  // namespace

CompiledCriterion compile(const Criterion& c, const NameTable& names, std::string_view source) {
    Compiler compiler{names, source, {}};
    compiler.add(c, -1, 0);
    CompiledCriterion& out = compiler.out;
    // conjunctive[n]: only and/seq nodes above n. Preorder puts every parent before its
    // children, so one pass suffices.
    std::vector<bool> conjunctive(out.nodes.size(), true);
    for (size_t n = 1; n < out.nodes.size(); ++n) {
        const int32_t p = out.nodes[n].parent;
        const Criterion::Kind k = out.nodes[p].kind;
        conjunctive[n] = conjunctive[p] && (k == Criterion::Kind::And || k == Criterion::Kind::Seq);
    }
    for (size_t i = 0; i < out.leaves.size(); ++i)
        if (conjunctive[out.leaves[i].node] && out.leaves[i].count.min >= 1)
            out.required.push_back(static_cast<int32_t>(i));
    return std::move(compiler.out);
}

// Streaming Evaluator
// The algorithm works on an EvaluatorStateRef so that StreamingEvaluator (own vectors) and
// EvaluatorBank (one shared buffer) run the same code.
namespace {

// Conditions 2 and 3 of the seed: every ancestor undefined, and under each seq ancestor all
// children left of the branch already true.
bool eligible(const CompiledCriterion& c, EvaluatorStateRef s, int32_t node) {
    int32_t child = node;
    for (int32_t p = c.nodes[node].parent; p >= 0; child = p, p = c.nodes[p].parent) {
        if (s.state[p] != CriterionState::Undefined) return false;
        if (c.nodes[p].kind == Criterion::Kind::Seq &&
            c.nodes[child].indexInParent != s.leadingTrue[p])
            return false;
    }
    return true;
}

CriterionState recompute(const CompiledCriterion& c, EvaluatorStateRef s, int32_t node) {
    const CompiledCriterion::Node& n = c.nodes[node];
    using K = Criterion::Kind;
    using S = CriterionState;
    if (n.kind == K::Not) {
        const S st = s.state[n.children[0]];
        return st == S::True ? S::False : st == S::False ? S::True : S::Undefined;
    }
    const S dominant = n.kind == K::Or ? S::True : S::False;  // decides alone
    bool allOther = true;
    for (int32_t ch : n.children) {
        if (s.state[ch] == dominant) return dominant;
        if (s.state[ch] == S::Undefined) allOther = false;
    }
    if (!allOther) return S::Undefined;
    return dominant == S::True ? S::False : S::True;
}

void setState(const CompiledCriterion& c, EvaluatorStateRef s, int32_t node, CriterionState st) {
    s.state[node] = st;
    const int32_t p = c.nodes[node].parent;
    if (p < 0) return;
    const CompiledCriterion::Node& parent = c.nodes[p];
    if (parent.kind == Criterion::Kind::Seq) {
        int32_t& k = s.leadingTrue[p];
        while (k < static_cast<int32_t>(parent.children.size()) &&
               s.state[parent.children[k]] == CriterionState::True)
            ++k;
    }
    if (s.state[p] != CriterionState::Undefined) return;
    const CriterionState ps = recompute(c, s, p);
    if (ps != CriterionState::Undefined) setState(c, s, p, ps);
}

}  // namespace

StreamingEvaluator::StreamingEvaluator(const CompiledCriterion& c) : c_(&c) { reset(); }

void StreamingEvaluator::reset() {
    state_.resize(c_->nodes.size());
    leadingTrue_.resize(c_->nodes.size());
    count_.resize(c_->leaves.size());
    reset(*c_, ref());
}

CriterionState StreamingEvaluator::push(const PathEvent& e) {
    return push(*c_, ref(), e, scratch_);
}

CriterionState StreamingEvaluator::finish() { return finish(*c_, ref(), scratch_); }

void StreamingEvaluator::reset(const CompiledCriterion& c, EvaluatorStateRef s) {
    std::fill_n(s.state, c.nodes.size(), CriterionState::Undefined);
    std::fill_n(s.leadingTrue, c.nodes.size(), 0);
    std::fill_n(s.count, c.leaves.size(), 0);
}

CriterionState StreamingEvaluator::push(const CompiledCriterion& c, EvaluatorStateRef s,
                                        const PathEvent& e, Scratch& scratch) {
    if (s.state[0] != CriterionState::Undefined) return s.state[0];
    // Eligibility is judged on the states before this event: one event advances a seq by at
    // most one step. Changes are applied after all leaves have seen the event.
    scratch.changed.clear();
    scratch.changedTo.clear();
    for (size_t i = 0; i < c.leaves.size(); ++i) {
        const CompiledCriterion::Leaf& leaf = c.leaves[i];
        if (s.state[leaf.node] != CriterionState::Undefined || !leaf.matches(e) ||
            !eligible(c, s, leaf.node))
            continue;
        const int32_t n = ++s.count[i];
        if (leaf.count.max == CountRange::kUnbounded) {
            if (n >= leaf.count.min) {
                scratch.changed.push_back(leaf.node);
                scratch.changedTo.push_back(CriterionState::True);
            }
        } else if (n > leaf.count.max) {
            scratch.changed.push_back(leaf.node);
            scratch.changedTo.push_back(CriterionState::False);
        }
    }
    for (size_t i = 0; i < scratch.changed.size(); ++i)
        setState(c, s, scratch.changed[i], scratch.changedTo[i]);
    return s.state[0];
}

CriterionState StreamingEvaluator::finish(const CompiledCriterion& c, EvaluatorStateRef s,
                                          Scratch& scratch) {
    if (s.state[0] != CriterionState::Undefined) return s.state[0];
    scratch.changed.clear();
    scratch.changedTo.clear();
    for (size_t i = 0; i < c.leaves.size(); ++i) {
        const CompiledCriterion::Leaf& leaf = c.leaves[i];
        if (s.state[leaf.node] != CriterionState::Undefined) continue;
        const bool in = s.count[i] >= leaf.count.min && s.count[i] <= leaf.count.max;
        scratch.changed.push_back(leaf.node);
        scratch.changedTo.push_back(in ? CriterionState::True : CriterionState::False);
    }
    for (size_t i = 0; i < scratch.changed.size(); ++i)
        setState(c, s, scratch.changed[i], scratch.changedTo[i]);
    return s.state[0];
}

// Evaluator Bank
EvaluatorBank::EvaluatorBank(std::span<const CompiledCriterion> criteria) : criteria_(criteria) {
    // Per criterion: counts, leading-true counts (int32), then node states (bytes), padded so
    // the next criterion's int32 arrays stay aligned. Each criterion's state is contiguous.
    const auto align4 = [](size_t n) { return (n + 3) & ~size_t{3}; };
    layout_.reserve(criteria.size());
    for (const CompiledCriterion& c : criteria) {
        Offsets o;
        o.count = bytes_;
        o.leadingTrue = o.count + c.leaves.size() * sizeof(int32_t);
        o.state = o.leadingTrue + c.nodes.size() * sizeof(int32_t);
        bytes_ = align4(o.state + c.nodes.size() * sizeof(CriterionState));
        for (const CompiledCriterion::Leaf& leaf : c.leaves) o.typeMask |= leaf.typeMask;
        layout_.push_back(o);
    }
}

void EvaluatorBank::reset(std::byte* buffer) const {
    for (size_t c = 0; c < criteria_.size(); ++c)
        StreamingEvaluator::reset(criteria_[c], ref(c, buffer));
}

bool matches(const CompiledCriterion& c, std::span<const PathEvent> events) {
    StreamingEvaluator ev(c);
    for (const PathEvent& e : events)
        if (ev.push(e) != CriterionState::Undefined) return ev.state() == CriterionState::True;
    return ev.finish() == CriterionState::True;
}

// Necessary-Condition Prefilter
void PathSummary::IdSet::insert(int32_t id) {
    const size_t word = static_cast<size_t>(id) / 64;
    if (word >= bits.size()) bits.resize(word + 1, 0);
    bits[word] |= uint64_t{1} << (id % 64);
    used = std::max(used, word + 1);
}

bool PathSummary::IdSet::intersects(const std::vector<uint64_t>& set) const {
    const size_t n = std::min(used, set.size());
    for (size_t w = 0; w < n; ++w)
        if (bits[w] & set[w]) return true;
    return false;
}

void PathSummary::IdSet::clear() {
    std::fill_n(bits.begin(), used, uint64_t{0});
    used = 0;
}

void PathSummary::reset() {
    types_ = mediumTypes_ = 0;
    for (int t = 0; t < kEventTypeCount; ++t) {
        objects_[t].clear();
        media_[t].clear();
    }
}

void PathSummary::add(const PathEvent& e) {
    const auto t = static_cast<unsigned>(e.type);
    types_ |= static_cast<uint16_t>(1u << t);
    if (e.object >= 0) objects_[t].insert(e.object);
    if (e.mediumBefore != e.mediumAfter) {
        mediumTypes_ |= static_cast<uint16_t>(1u << t);
        if (e.mediumAfter >= 0) media_[t].insert(e.mediumAfter);
    }
}

// Whether some event of the path matches the leaf, exactly as Leaf::matches decides it.
bool PathSummary::satisfiable(const CompiledCriterion::Leaf& leaf) const {
    const uint16_t seen = (leaf.useMedium ? mediumTypes_ : types_) & leaf.typeMask;
    if (leaf.anyObject) return seen != 0;
    const IdSet* ids = leaf.useMedium ? media_ : objects_;
    for (unsigned m = seen; m != 0; m &= m - 1)
        if (ids[std::countr_zero(m)].intersects(leaf.set)) return true;
    return false;
}

bool PathSummary::mayMatch(const CompiledCriterion& c) const {
    for (int32_t i : c.required)
        if (!satisfiable(c.leaves[i])) return false;
    return true;
}

// Direct Evaluator
// The definition of docs/criteria.md: a node opened at event index t sees events t, t+1, ...;
// it yields its value and the index at which it became known (N = at the end of the path).
namespace {

DirectResult direct(const CompiledCriterion& c, int32_t node, size_t t,
                    std::span<const PathEvent> ev) {
    const size_t n = ev.size();
    const CompiledCriterion::Node& nd = c.nodes[node];
    switch (nd.kind) {
        case Criterion::Kind::Leaf: {
            const CompiledCriterion::Leaf& leaf = c.leaves[nd.leaf];
            int count = 0;
            for (size_t i = t; i < n; ++i) {
                if (!leaf.matches(ev[i])) continue;
                ++count;
                if (leaf.count.max == CountRange::kUnbounded && count >= leaf.count.min)
                    return {true, i};
                if (count > leaf.count.max) return {false, i};
            }
            return {count >= leaf.count.min && count <= leaf.count.max, n};
        }
        case Criterion::Kind::Not: {
            const DirectResult r = direct(c, nd.children[0], t, ev);
            return {!r.value, r.decidedAt};
        }
        case Criterion::Kind::And:
        case Criterion::Kind::Or: {
            // And: false at the first false child, else true when the last child is.
            const bool dominant = nd.kind == Criterion::Kind::Or;
            bool anyDominant = false;
            size_t first = n, last = 0;
            for (int32_t ch : nd.children) {
                const DirectResult r = direct(c, ch, t, ev);
                if (r.value == dominant) {
                    anyDominant = true;
                    first = std::min(first, r.decidedAt);
                }
                last = std::max(last, r.decidedAt);
            }
            return anyDominant ? DirectResult{dominant, first} : DirectResult{!dominant, last};
        }
        case Criterion::Kind::Seq: {
            // Child k opens at the event after the one that made child k-1 true.
            size_t open = t, last = 0;
            for (int32_t ch : nd.children) {
                const DirectResult r = direct(c, ch, open, ev);
                if (!r.value) return {false, r.decidedAt};
                last = r.decidedAt;
                open = r.decidedAt + 1;
            }
            return {true, last};
        }
    }
    return {false, n};
}

}  // namespace

DirectResult evaluateDirect(const CompiledCriterion& c, std::span<const PathEvent> events) {
    return direct(c, 0, 0, events);
}

CompiledCriterion compileCriterion(std::string_view text, const NameTable& names,
                                   std::string_view source) {
    return compile(parseCriterion(text, source), names, source);
}

std::vector<CompiledCriterion> compileWhereList(const std::vector<std::string>& where,
                                                const NameTable& names) {
    std::vector<CompiledCriterion> compiled;
    compiled.reserve(where.size());
    for (size_t k = 0; k < where.size(); ++k)
        compiled.push_back(compileCriterion(where[k], names, "--where " + std::to_string(k + 1)));
    return compiled;
}

}  // namespace veil
