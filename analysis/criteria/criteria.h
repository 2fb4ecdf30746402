#pragma once
// Ray path criteria: select rays by what happened to them (the seed's section 2.1).
//
// A criterion is a tree. Its leaves are elementary events (emitted by a source, hits an
// object, a detector, a surface property, enters a medium, or an event type at an object),
// each with a count requirement; its nodes are and, or, not and seq (children in order).
// The text syntax, the OpticStudio filter syntax and the exact semantics are in
// docs/criteria.md.
//
//   text ──parseCriterion──> Criterion ──compile(NameTable)──> CompiledCriterion
//                                                                   │
//        PathEvent ... PathEvent ──push──> StreamingEvaluator ──> True / False / Undefined
//
// Compilation turns object, property, medium and source patterns into bitsets, so evaluation
// does integer tests only. The streaming evaluator keeps one state per node (memory linear in
// the tree, no automaton) and decides as soon as the events allow it; evaluateDirect is an
// independent recursive evaluator of the same semantics, used as the tests' oracle.

#include <cstddef>
#include <cstdint>
#include <limits>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lensdata/errors.h"
#include "tracer/records/path_history.h"
#include "tracer/surfaces/property_table.h"  // globMatch

namespace veil {

// Criterion AST
enum class LeafKind : uint8_t {
    Emit,             // emit(S): emitted by source S
    Hit,              // hit(O): any event at object O (a detector hit included)
    Detector,         // detector(D): recorded by detector D
    Property,         // property(P): any event at a surface whose optical property is P
    Medium,           // medium(M): refracts into medium M
    Reflect,          // specular or Fresnel ghost reflection
    Fresnel,          // Fresnel ghost reflection only
    Tir,              // total internal reflection
    Refract,          // specular transmission
    Scatter,          // scatter, reflected or transmitted
    ScatterReflect,   // scatter back into the incident medium
    ScatterTransmit,  // scatter through the surface
    Absorb,           // surface or volume absorption
    Exit,             // leaves the scene
};
inline constexpr int kLeafKindCount = 14;
std::string_view toString(LeafKind k);  // the keyword of the text syntax
std::ostream& operator<<(std::ostream& os, LeafKind k);

// How many matching events a leaf needs: min <= count <= max. The default is "at least one".
struct CountRange {
    static constexpr int kUnbounded = std::numeric_limits<int>::max();
    int min = 1;
    int max = kUnbounded;
    bool operator==(const CountRange&) const = default;
};
std::ostream& operator<<(std::ostream& os, const CountRange& c);

// One alternative of a leaf's pattern list: a glob (* and ?) or "#n", an id.
struct NamePattern {
    std::string text;
    int column = 0;  // where it starts in the source text (1-based), 0 if built in code
    bool operator==(const NamePattern& o) const { return text == o.text; }
};

struct Criterion {
    enum class Kind : uint8_t { Leaf, And, Or, Not, Seq };
    Kind kind = Kind::Leaf;
    LeafKind leaf = LeafKind::Hit;      // leaves only
    std::vector<NamePattern> patterns;  // leaves only; empty = any
    CountRange count;                   // leaves only
    std::vector<Criterion> children;    // And, Or, Seq: >= 1; Not: exactly 1
    int column = 0;                     // source position (1-based), 0 if built in code

    size_t nodeCount() const;
    bool operator==(const Criterion& o) const {
        return kind == o.kind && leaf == o.leaf && patterns == o.patterns && count == o.count &&
               children == o.children;
    }
};
// Prints the criterion in the text syntax; parseCriterion reads it back to an equal tree.
std::ostream& operator<<(std::ostream& os, const Criterion& c);
std::string toString(const Criterion& c);

// Groups, seq(...), not and '!' nest at most this deep: the parsers, and everything that walks
// a criterion's tree, recurse once per level. Deeper text is a ParseError at the level that
// goes past it.
inline constexpr int kMaxCriterionNesting = 200;

// Parses the text syntax (docs/criteria.md). Throws ParseError{source, 1, column}.
Criterion parseCriterion(std::string_view text, std::string_view source = "<criterion>");
// Parses an OpticStudio-style filter string (H7 & !R6 | S3) into the same tree, object
// numbers becoming "#n" id patterns. Throws ParseError{source, 1, column}.
Criterion parseZemaxFilter(std::string_view text, std::string_view source = "<filter>");

// Name Resolution
// What the names in a criterion refer to. Object i of `objects` has id i.
struct NameTable {
    struct Object {
        std::string name;
        std::vector<std::string> aliases;
        std::string property;  // optical property name ("" = none)
        bool detector = false;
    };
    std::vector<Object> objects;
    std::vector<std::string> media;    // index = medium id
    std::vector<std::string> sources;  // index = source index (the Emit event's object)
};

// A criterion with names replaced by bitsets, laid out flat (node 0 is the root, a node's
// children follow it in preorder).
struct CompiledCriterion {
    struct Node {
        Criterion::Kind kind = Criterion::Kind::Leaf;
        int32_t parent = -1;
        int32_t indexInParent = 0;  // position among its parent's children
        std::vector<int32_t> children;
        int32_t leaf = -1;  // index into leaves for Leaf nodes
    };
    struct Leaf {
        int32_t node = -1;
        uint16_t typeMask = 0;      // bit t set: EventType t can match
        bool anyObject = false;     // matches any object id, none (-1) included
        bool useMedium = false;     // Medium leaves test mediumAfter, not the object
        std::vector<uint64_t> set;  // object ids (or media, or sources) that match
        CountRange count;
        bool matches(const PathEvent& e) const;
    };
    std::vector<Node> nodes;
    std::vector<Leaf> leaves;
    // Leaves every matching path must match at least once (indices into leaves): count.min
    // >= 1 and only and/seq nodes above them, so the root cannot be true unless they are,
    // and a true leaf has counted min matching events. PathSummary::mayMatch tests them.
    std::vector<int32_t> required;
};

// Resolves every pattern. A pattern that matches nothing is a ParseError naming it, at its
// column in `source`.
CompiledCriterion compile(const Criterion& c, const NameTable& names,
                          std::string_view source = "<criterion>");
// Text to compiled criterion in one step, the one way commands and analyses read criteria:
// parseCriterion() then compile(), both errors naming `source` (the option, "--where 2", or
// the ghost the text belongs to) and the column.
CompiledCriterion compileCriterion(std::string_view text, const NameTable& names,
                                   std::string_view source = "<criterion>");
// A command's --where list, compiled in the one place every command and run does it: entry
// k's errors name "--where k" (1-based), so a mistake points at the option that holds it.
std::vector<CompiledCriterion> compileWhereList(const std::vector<std::string>& where,
                                                const NameTable& names);

// Streaming Evaluation
enum class CriterionState : uint8_t { Undefined, True, False };
std::ostream& operator<<(std::ostream& os, CriterionState s);

// The state of one streaming evaluator in memory owned by someone else (EvaluatorBank keeps
// many in one buffer): one entry per node, one leading-true count per node (used by Seq nodes
// only), one match count per leaf.
struct EvaluatorStateRef {
    CriterionState* state;
    int32_t* leadingTrue;
    int32_t* count;
};

// The seed's three-state evaluator. Events are pushed one by one in path order; the answer is
// known as soon as decided(). Pushing more events after that changes nothing. One evaluator
// per thread; reset() before every path (memory is reused).
class StreamingEvaluator {
  public:
    explicit StreamingEvaluator(const CompiledCriterion& c);
    void reset();
    CriterionState push(const PathEvent& e);
    // End of the path: undefined leaves decide from their counts, the root is never Undefined.
    CriterionState finish();
    bool decided() const { return state_[0] != CriterionState::Undefined; }
    CriterionState state() const { return state_[0]; }

    // The same algorithm on external state (sized for c), for callers that lay out the state
    // of many evaluators themselves. `scratch` is reused memory, its contents do not matter.
    struct Scratch {
        std::vector<int32_t> changed;  // leaves decided by the current event
        std::vector<CriterionState> changedTo;
    };
    static void reset(const CompiledCriterion& c, EvaluatorStateRef s);
    static CriterionState push(const CompiledCriterion& c, EvaluatorStateRef s, const PathEvent& e,
                               Scratch& scratch);
    static CriterionState finish(const CompiledCriterion& c, EvaluatorStateRef s, Scratch& scratch);

  private:
    EvaluatorStateRef ref() { return {state_.data(), leadingTrue_.data(), count_.data()}; }

    const CompiledCriterion* c_;
    std::vector<CriterionState> state_;  // per node
    std::vector<int32_t> leadingTrue_;   // per Seq node: how many first children are true
    std::vector<int32_t> count_;         // per leaf
    Scratch scratch_;
};

// The streaming evaluators of several criteria with all their state in one flat buffer, laid
// out by offsets computed once. Copying the buffer copies every evaluator: the online filter
// (analysis/criteria/criterion_images.h) copies a branch's state at every split, and one allocation
// and memcpy is much cheaper than a vector per criterion and per node array. The criteria
// must outlive the bank; a buffer holds bufferSize() bytes, suitably aligned (new / vector).
class EvaluatorBank {
  public:
    explicit EvaluatorBank(std::span<const CompiledCriterion> criteria);
    size_t size() const { return criteria_.size(); }
    size_t bufferSize() const { return bytes_; }
    // Every evaluator back to the start of a path.
    void reset(std::byte* buffer) const;
    // Criterion c's evaluator (StreamingEvaluator::push / finish / state on its part).
    CriterionState push(size_t c, std::byte* buffer, const PathEvent& e,
                        StreamingEvaluator::Scratch& scratch) const {
        // An event no leaf can match changes nothing: skip the evaluator (most events, with
        // criteria that look for a few event types).
        if (!((layout_[c].typeMask >> static_cast<unsigned>(e.type)) & 1u)) return state(c, buffer);
        return StreamingEvaluator::push(criteria_[c], ref(c, buffer), e, scratch);
    }
    CriterionState finish(size_t c, std::byte* buffer, StreamingEvaluator::Scratch& scratch) const {
        return StreamingEvaluator::finish(criteria_[c], ref(c, buffer), scratch);
    }
    CriterionState state(size_t c, const std::byte* buffer) const {
        return *reinterpret_cast<const CriterionState*>(buffer + layout_[c].state);
    }

  private:
    struct Offsets {
        size_t state, leadingTrue, count;  // byte offsets into the buffer
        uint16_t typeMask = 0;             // the event types some leaf can match
    };
    EvaluatorStateRef ref(size_t c, std::byte* buffer) const {
        const Offsets& o = layout_[c];
        return {reinterpret_cast<CriterionState*>(buffer + o.state),
                reinterpret_cast<int32_t*>(buffer + o.leadingTrue),
                reinterpret_cast<int32_t*>(buffer + o.count)};
    }

    std::span<const CompiledCriterion> criteria_;
    std::vector<Offsets> layout_;
    size_t bytes_ = 0;
};

// Evaluates a whole path (streaming, stopping early); true if it matches.
bool matches(const CompiledCriterion& c, std::span<const PathEvent> events);

// Necessary-Condition Prefilter
// Which (event type, object) and (event type, medium entered) pairs occur in one path, so
// that many criteria can be rejected without running an evaluator: mayMatch is false only if
// a required leaf matches no event of the path, and then the criterion is false on it.
// It ignores order and counts, so true decides nothing. One summary per thread; reset()
// before every path (memory is reused).
class PathSummary {
  public:
    void reset();
    void add(const PathEvent& e);
    bool mayMatch(const CompiledCriterion& c) const;

  private:
    // The ids (objects or media) seen with one event type. Words from `used` on are zero, so
    // clear() touches only the ones a path set.
    struct IdSet {
        std::vector<uint64_t> bits;
        size_t used = 0;
        void insert(int32_t id);
        bool intersects(const std::vector<uint64_t>& set) const;
        void clear();
    };
    bool satisfiable(const CompiledCriterion::Leaf& leaf) const;

    uint16_t types_ = 0;        // bit t: an event of type t, any object (-1 included)
    uint16_t mediumTypes_ = 0;  // bit t: an event of type t that changes the medium
    IdSet objects_[kEventTypeCount];
    IdSet media_[kEventTypeCount];  // mediumAfter of the medium-changing events
};

// Direct Evaluation (test oracle)
// The recursive definition of docs/criteria.md, independent of StreamingEvaluator. Returns the
// value and the index of the event at which it became known (events.size() = at the end).
struct DirectResult {
    bool value = false;
    size_t decidedAt = 0;
};
DirectResult evaluateDirect(const CompiledCriterion& c, std::span<const PathEvent> events);

}  // namespace veil
