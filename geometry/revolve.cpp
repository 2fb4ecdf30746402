#include "geometry/revolve.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace veil {

namespace {

[[noreturn]] void fail(const std::string& what) {
    throw std::invalid_argument("revolveProfile: " + what);
}

double cross(const Vec2& a, const Vec2& b) { return a.x * b.y - a.y * b.x; }

// Orientation of c relative to the line a -> b: +1 left, -1 right, 0 on the line.
int orientation(const Vec2& a, const Vec2& b, const Vec2& c) {
    const double d = cross(b - a, c - a);
    return (d > 0.0) - (d < 0.0);
}

bool onSegment(const Vec2& a, const Vec2& b, const Vec2& p) {
    return std::min(a.x, b.x) <= p.x && p.x <= std::max(a.x, b.x) && std::min(a.y, b.y) <= p.y &&
           p.y <= std::max(a.y, b.y);
}

// Closed segments [a, b] and [c, d] share a point.
bool segmentsMeet(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
    const int o1 = orientation(a, b, c), o2 = orientation(a, b, d);
    const int o3 = orientation(c, d, a), o4 = orientation(c, d, b);
    if (o1 != o2 && o3 != o4) return true;
    return (o1 == 0 && onSegment(a, b, c)) || (o2 == 0 && onSegment(a, b, d)) ||
           (o3 == 0 && onSegment(c, d, a)) || (o4 == 0 && onSegment(c, d, b));
}

std::string vertexText(size_t i, const Vec2& p) {
    std::ostringstream os;
    os << "vertex " << i << " (r = " << p.x << ", z = " << p.y << ")";
    return os.str();
}

}  // namespace

// Profile Checks

std::string profileDefect(std::span<const Vec2> p) {
    const size_t n = p.size();
    if (n < 3) return "a profile needs at least 3 vertices (got " + std::to_string(n) + ")";
    for (size_t i = 0; i < n; ++i) {
        if (!std::isfinite(p[i].x) || !std::isfinite(p[i].y))
            return vertexText(i, p[i]) + " is not finite";
        if (p[i].x < 0.0) return vertexText(i, p[i]) + " has r < 0";
        if (p[i] == p[(i + 1) % n]) return vertexText(i, p[i]) + " repeats the next vertex";
    }
    if (!(profileArea(p) > 0.0))
        return "the profile is not counter-clockwise in (r, z) (area <= 0)";
    // Simple polygon: non-consecutive edges do not meet; consecutive ones only at their
    // common vertex (no fold back along the same line).
    for (size_t i = 0; i < n; ++i) {
        const Vec2 &a = p[i], &b = p[(i + 1) % n];
        for (size_t j = i + 1; j < n; ++j) {
            const Vec2 &c = p[j], &d = p[(j + 1) % n];
            const bool next = j == i + 1, prev = i == 0 && j == n - 1;
            if (next || prev) {
                // Consecutive edges: they share one vertex; they must not overlap along a line.
                const Vec2& shared = next ? b : a;
                const Vec2& other1 = next ? a : b;
                const Vec2& other2 = next ? d : c;
                if (orientation(other1, shared, other2) == 0 &&
                    glm::dot(other1 - shared, other2 - shared) > 0.0)
                    return "edges " + std::to_string(i) + " and " + std::to_string(j) +
                           " fold back on each other";
                continue;
            }
            if (segmentsMeet(a, b, c, d))
                return "edges " + std::to_string(i) + " and " + std::to_string(j) +
                       " cross or touch: the profile is not a simple polygon";
        }
    }
    return "";
}

// Chord Error and Segment Count

double chordError(double rMaxMm, int segments) {
    return rMaxMm * (1.0 - std::cos(std::numbers::pi / segments));
}

int chordSegmentCount(double rMaxMm, double chordToleranceMm) {
    if (!(chordToleranceMm > 0.0) || !std::isfinite(chordToleranceMm))
        throw std::invalid_argument("chordSegmentCount: the chord tolerance must be > 0");
    if (!(rMaxMm >= 0.0) || !std::isfinite(rMaxMm))
        throw std::invalid_argument("chordSegmentCount: the radius must be finite and >= 0");
    constexpr int kMaxSegments = 1 << 20;
    const double ratio = chordToleranceMm / rMaxMm;
    if (ratio >= 0.5) return 3;  // 1 - cos(pi / 3) = 0.5
    int n = static_cast<int>(std::ceil(std::numbers::pi / std::acos(1.0 - ratio)));
    n = std::max(n, 3);
    // Guard the rounding of acos near 1.
    while (n > 3 && chordError(rMaxMm, n - 1) <= chordToleranceMm) --n;
    while (chordError(rMaxMm, n) > chordToleranceMm) {
        if (++n > kMaxSegments)
            throw std::invalid_argument("chordSegmentCount: more than 2^20 segments needed");
    }
    return n;
}

// Profile Measures

double profileArea(std::span<const Vec2> p) {
    double a = 0.0;
    for (size_t i = 0; i < p.size(); ++i) a += cross(p[i], p[(i + 1) % p.size()]);
    return 0.5 * a;
}

double profileRevolvedVolume(std::span<const Vec2> p) {
    // integral of r over the polygon by Green's theorem: (1/6) sum (r_i + r_j) cross_ij.
    double m = 0.0;
    for (size_t i = 0; i < p.size(); ++i) {
        const Vec2 &a = p[i], &b = p[(i + 1) % p.size()];
        m += (a.x + b.x) * cross(a, b);
    }
    return 2.0 * std::numbers::pi * m / 6.0;
}

std::ostream& operator<<(std::ostream& os, const RevolvedMesh& m) {
    return os << "RevolvedMesh{" << m.mesh << ", " << m.segments << " segments, "
              << (m.edgeFirstTriangle.empty() ? 0 : m.edgeFirstTriangle.size() - 1)
              << " profile edges}";
}

// Revolution

RevolvedMesh revolveProfile(std::span<const Vec2> profile, int segments) {
    if (segments < 3) fail("at least 3 angular segments are needed");
    if (const std::string defect = profileDefect(profile); !defect.empty()) fail(defect);
    const size_t n = profile.size();
    const auto N = static_cast<uint32_t>(segments);

    // Unit directions of the N meridians; phi_0 = 0 exactly.
    std::vector<double> cosPhi(N), sinPhi(N);
    for (uint32_t k = 0; k < N; ++k) {
        const double phi = 2.0 * std::numbers::pi * k / N;
        cosPhi[k] = k == 0 ? 1.0 : std::cos(phi);
        sinPhi[k] = k == 0 ? 0.0 : std::sin(phi);
    }

    RevolvedMesh out;
    out.segments = segments;
    TriangleMesh& m = out.mesh;
    // First mesh vertex of every profile vertex: a ring of N, or one pole on the axis.
    std::vector<uint32_t> first(n);
    for (size_t i = 0; i < n; ++i) {
        first[i] = static_cast<uint32_t>(m.vertices.size());
        const Vec2& p = profile[i];
        if (p.x == 0.0) {
            m.vertices.emplace_back(0.0, 0.0, p.y);
        } else {
            for (uint32_t k = 0; k < N; ++k)
                m.vertices.emplace_back(p.x * cosPhi[k], p.x * sinPhi[k], p.y);
        }
    }
    auto at = [&](size_t i, uint32_t k) {
        return profile[i].x == 0.0 ? first[i] : first[i] + k % N;
    };

    // Edge P -> Q between meridians k and k+1: A = P_k, B = Q_k, C = Q_k+1, D = P_k+1. With the
    // interior of the profile on the left of P -> Q, (A, D, C) and (A, C, B) face outward.
    out.edgeFirstTriangle.reserve(n + 1);
    for (size_t i = 0; i < n; ++i) {
        out.edgeFirstTriangle.push_back(static_cast<uint32_t>(m.triangles.size()));
        const size_t j = (i + 1) % n;
        const bool pOnAxis = profile[i].x == 0.0, qOnAxis = profile[j].x == 0.0;
        if (pOnAxis && qOnAxis) continue;  // along the axis: no surface
        for (uint32_t k = 0; k < N; ++k) {
            const uint32_t a = at(i, k), b = at(j, k), c = at(j, k + 1), d = at(i, k + 1);
            if (pOnAxis) {
                m.triangles.push_back({a, c, b});
            } else if (qOnAxis) {
                m.triangles.push_back({a, d, b});
            } else {
                m.triangles.push_back({a, d, c});
                m.triangles.push_back({a, c, b});
            }
        }
    }
    out.edgeFirstTriangle.push_back(static_cast<uint32_t>(m.triangles.size()));
    return out;
}

}  // namespace veil
