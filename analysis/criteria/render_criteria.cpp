#include "analysis/criteria/render_criteria.h"

#include <cstring>
#include <deque>
#include <mutex>
#include <set>
#include <stdexcept>

#include "tracer/records/path_history.h"

namespace veil {

namespace {

StreamingEvaluator::Scratch& threadScratch() {
    thread_local StreamingEvaluator::Scratch scratch;
    return scratch;
}

// The bytes of a suffix that decide its verdict: what Leaf::matches reads.
std::string suffixKey(std::span<const PathEvent> suffix) {
    std::string key;
    key.reserve(suffix.size() * 9);
    for (const PathEvent& e : suffix) {
        key.push_back(static_cast<char>(e.type));
        key.append(reinterpret_cast<const char*>(&e.object), sizeof e.object);
        key.append(reinterpret_cast<const char*>(&e.mediumBefore), sizeof e.mediumBefore);
        key.append(reinterpret_cast<const char*>(&e.mediumAfter), sizeof e.mediumAfter);
    }
    return key;
}

constexpr size_t kMaxCachedSuffixes = 1u << 20;

}  // namespace

RenderCriteria::RenderCriteria(std::vector<CompiledCriterion> criteria, const NameTable& names)
    : criteria_(std::move(criteria)), bank_(criteria_) {
    if (criteria_.size() > 64) throw std::invalid_argument("RenderCriteria: at most 64 criteria");
    single_.reserve(criteria_.size());
    for (size_t c = 0; c < criteria_.size(); ++c)
        single_.emplace_back(std::span<const CompiledCriterion>(&criteria_[c], 1));
    for (size_t c = 0; c < criteria_.size(); ++c) prefix_.push_back(enumeratePrefixes(c, names));
}

uint64_t RenderCriteria::push(std::byte* state, const PathEvent& e) const {
    StreamingEvaluator::Scratch& scratch = threadScratch();
    uint64_t alive = 0;
    for (size_t c = 0; c < criteria_.size(); ++c) {
        if (bank_.state(c, state) == CriterionState::False) continue;
        if (bank_.push(c, state, e, scratch) != CriterionState::False) alive |= uint64_t{1} << c;
    }
    return alive;
}

uint64_t RenderCriteria::matches(const std::byte* state, std::span<const PathEvent> suffix,
                                 std::byte* scratchState) const {
    StreamingEvaluator::Scratch& scratch = threadScratch();
    std::memcpy(scratchState, state, bank_.bufferSize());
    uint64_t yes = 0;
    for (size_t c = 0; c < criteria_.size(); ++c) {
        CriterionState s = bank_.state(c, scratchState);
        for (size_t i = 0; i < suffix.size() && s == CriterionState::Undefined; ++i)
            s = bank_.push(c, scratchState, suffix[i], scratch);
        if (s == CriterionState::Undefined) s = bank_.finish(c, scratchState, scratch);
        if (s == CriterionState::True) yes |= uint64_t{1} << c;
    }
    return yes;
}

uint64_t RenderCriteria::suffixMayMatch(std::span<const PathEvent> suffix) const {
    const std::string key = suffixKey(suffix);
    {
        std::shared_lock lock(cacheMutex_);
        const auto it = cache_.find(key);
        if (it != cache_.end()) return it->second;
    }
    StreamingEvaluator::Scratch& scratch = threadScratch();
    uint64_t may = 0;
    for (size_t c = 0; c < criteria_.size(); ++c) {
        const Prefixes& p = prefix_[c];
        const uint64_t bit = uint64_t{1} << c;
        if (!p.enumerated || p.anyTrue) {
            may |= bit;
            continue;
        }
        const EvaluatorBank& bank = single_[c];
        std::vector<std::byte> s(bank.bufferSize());
        for (const std::vector<std::byte>& start : p.states) {
            std::memcpy(s.data(), start.data(), s.size());
            CriterionState st = CriterionState::Undefined;
            for (size_t i = 0; i < suffix.size() && st == CriterionState::Undefined; ++i)
                st = bank.push(0, s.data(), suffix[i], scratch);
            if (st == CriterionState::Undefined) st = bank.finish(0, s.data(), scratch);
            if (st == CriterionState::True) {
                may |= bit;
                break;
            }
        }
    }
    std::unique_lock lock(cacheMutex_);
    if (cache_.size() < kMaxCachedSuffixes) cache_.emplace(key, may);
    return may;
}

RenderCriteria::Prefixes RenderCriteria::enumeratePrefixes(size_t c, const NameTable& names) const {
    const CompiledCriterion& cc = criteria_[c];
    // One representative event per distinct set of matching leaves. Emit events first (a
    // prefix starts with one), then every other type a prefix can hold at every object (or
    // none) with the medium unchanged and changed into each medium.
    auto leafSet = [&](const PathEvent& e) {
        std::vector<bool> set(cc.leaves.size());
        for (size_t i = 0; i < cc.leaves.size(); ++i) set[i] = cc.leaves[i].matches(e);
        return set;
    };
    std::vector<PathEvent> emits, events;
    {
        std::set<std::vector<bool>> seen;
        const size_t sources = std::max<size_t>(names.sources.size(), 1);
        for (size_t s = 0; s < sources; ++s) {
            PathEvent e;
            e.type = EventType::Emit;
            e.object = static_cast<int32_t>(s);
            if (seen.insert(leafSet(e)).second) emits.push_back(e);
        }
        seen.clear();
        const int media = std::max<int>(static_cast<int>(names.media.size()), 1);
        for (int t = 1; t < kEventTypeCount; ++t) {
            // A photon's path before the view point neither ends (absorption, exit, cull) nor
            // meets a detector (detectors absorb): such events cannot be in a prefix.
            const EventType type = static_cast<EventType>(t);
            if (isTerminal(type) || type == EventType::DetectorHit) continue;
            for (int o = -1; o < static_cast<int>(names.objects.size()); ++o)
                for (int m = 0; m < media; ++m)
                    for (int changed = 0; changed < 2; ++changed) {
                        if (changed && media < 2) continue;
                        PathEvent e;
                        e.type = static_cast<EventType>(t);
                        e.object = o;
                        e.mediumAfter = static_cast<int16_t>(m);
                        e.mediumBefore = static_cast<int16_t>(changed ? (m + 1) % media : m);
                        if (seen.insert(leafSet(e)).second) events.push_back(e);
                    }
        }
    }
    const EvaluatorBank& bank = single_[c];
    StreamingEvaluator::Scratch& scratch = threadScratch();
    Prefixes out;
    std::set<std::string> seen;  // the states' bytes
    std::deque<std::vector<std::byte>> frontier;
    std::vector<std::byte> start(bank.bufferSize());
    bank.reset(start.data());
    auto visit = [&](std::vector<std::byte> s) {
        const CriterionState st = bank.state(0, s.data());
        if (st == CriterionState::True) out.anyTrue = true;
        if (st != CriterionState::Undefined) return;
        std::string key(reinterpret_cast<const char*>(s.data()), s.size());
        if (seen.insert(std::move(key)).second) frontier.push_back(std::move(s));
    };
    for (const PathEvent& e : emits) {
        std::vector<std::byte> s = start;
        bank.push(0, s.data(), e, scratch);
        visit(std::move(s));
    }
    while (!frontier.empty() && !out.anyTrue) {
        if (seen.size() > kMaxPrefixStates) return Prefixes{};  // not enumerated
        const std::vector<std::byte> s = std::move(frontier.front());
        frontier.pop_front();
        for (const PathEvent& e : events) {
            std::vector<std::byte> next = s;
            bank.push(0, next.data(), e, scratch);
            visit(std::move(next));
        }
    }
    out.enumerated = true;
    if (!out.anyTrue)
        for (const std::string& key : seen) {
            const auto* b = reinterpret_cast<const std::byte*>(key.data());
            out.states.emplace_back(b, b + key.size());
        }
    return out;
}

}  // namespace veil
