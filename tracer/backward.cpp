#include "tracer/backward.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace veil {

std::ostream& operator<<(std::ostream& os, const BackwardOptions& o) {
    return os << "BackwardOptions{" << o.raysPerPixel << " rays per pixel, seed " << o.seed
              << (o.split ? ", split" : ", random") << ", depth " << o.maxSpecularDepth
              << ", min weight " << o.minRelativeWeight << "}";
}

std::ostream& operator<<(std::ostream& os, const ViewPoint& v) {
    return os << "ViewPoint{object " << v.object << " at " << v.positionMm << " to detector "
              << v.toDetector << ", pixel " << v.pixel << ", wavelength " << v.wavelength
              << ", weight " << v.weight << "}";
}

double BackwardResult::visibleTotalVariance(uint64_t raysPerPixel) const {
    double v = 0.0;
    for (int p = 0; p < visible.pixelCount(); ++p) v += visible.pixelVariance(p, raysPerPixel);
    return v;
}

namespace {

struct Branch {
    Ray ray;
    double weight = 0.0;
    int startObject = -1;
    int startPrimitive = -1;
    int medium = 0;
    int depth = 0;
};

// What the rays of one pixel produced, merged in pixel order afterwards.
struct PixelOutput {
    std::vector<double> visible;  // per ray, its visible-source flux
    std::vector<ViewPoint> viewPoints;
    uint64_t segments = 0;
};

}  // namespace

BackwardResult traceBackward(const TransportScene& ts, const DetectorImage& detector,
                             const ExitAperture& aperture, const BackwardOptions& options) {
    if (options.raysPerPixel == 0)
        throw std::invalid_argument("traceBackward: raysPerPixel must be at least 1");
    if (!(aperture.radiusMm > 0.0))
        throw std::invalid_argument("traceBackward: the exit aperture has no area");
    const Scene& scene = *ts.scene;
    const MediaOptics& media = *ts.media;
    const int wavelengths = media.wavelengthCount();
    const int detectorObject = detector.geometry().object;
    const uint64_t perPixel = options.raysPerPixel;
    const int pixels = detector.pixelCount();

    std::vector<PixelOutput> out(static_cast<size_t>(pixels));
    tbb::parallel_for(tbb::blocked_range<int>(0, pixels, 64), [&](const tbb::blocked_range<int>& r) {
        std::vector<Branch> stack;
        for (int p = r.begin(); p != r.end(); ++p) {
            PixelOutput& po = out[static_cast<size_t>(p)];
            po.visible.assign(perPixel, 0.0);
            for (uint64_t k = 0; k < perPixel; ++k) {
                CounterRng rng(options.seed, static_cast<uint64_t>(p) * perPixel + k);
                const PixelRay pr = samplePixelRay(detector, p, aperture, rng);
                const double u = rng.uniform();  // the wavelength
                if (!(pr.pdf > 0.0) || !(pr.importance > 0.0) || !(pr.cosPixel > 0.0)) continue;
                const int w = std::min(wavelengths - 1, static_cast<int>(u * wavelengths));
                const double wavelengthNm = media.wavelengthNm(w);
                const double start = pr.importance * pr.cosPixel / pr.pdf /
                                     static_cast<double>(perPixel) * wavelengths;
                double seen = 0.0;
                stack.clear();
                stack.push_back({pr.ray, start, detectorObject, -1, 0, 0});
                while (!stack.empty()) {
                    Branch br = stack.back();
                    stack.pop_back();
                    const auto hit = scene.closestHit(br.ray, kInfinity, br.startObject,
                                                      br.startPrimitive);
                    const double tHit = hit ? hit->t : kInfinity;
                    // Sources seen along the segment (they block nothing).
                    const double alpha = media.absorptionPerMm(br.medium, w);
                    for (const Source& s : ts.sources) {
                        const auto t = s.crossing(br.ray, tHit);
                        if (!t) continue;
                        const Vec3 x = br.ray.origin + *t * br.ray.direction;
                        const double radiance = s.emitted(x, -br.ray.direction, w);
                        seen += br.weight * (alpha > 0.0 ? std::exp(-alpha * *t) : 1.0) * radiance;
                    }
                    if (!hit) continue;
                    ++po.segments;
                    if (alpha > 0.0) br.weight *= std::exp(-alpha * hit->t);
                    if (hit->object == detectorObject ||
                        ts.detectorOfObject[hit->object] >= 0)
                        continue;  // a detector absorbs
                    const Interaction in = interact(ts, *hit, br.ray.direction, w, wavelengthNm,
                                                    TransportMode::Importance);
                    bool scatters = false;
                    double specular = 0.0;
                    for (int c = 0; c < in.count; ++c) {
                        scatters |= in.children[c].scatter;
                        if (!in.children[c].scatter) specular += in.children[c].share;
                    }
                    if (scatters) {
                        ViewPoint v;
                        v.positionMm = hit->point;
                        v.normal = hit->normal;
                        v.toDetector = -br.ray.direction;
                        v.object = hit->object;
                        v.primitive = hit->primitive;
                        v.pixel = p;
                        v.wavelength = w;
                        v.medium = hit->mediumFrom;
                        v.weight = br.weight;
                        po.viewPoints.push_back(v);
                    }
                    if (!(specular > 0.0) || br.depth >= options.maxSpecularDepth) continue;
                    auto push = [&](const InteractionChild& c, double weight) {
                        Branch next;
                        next.ray = {hit->point, c.direction};
                        next.weight = weight;
                        next.startObject = hit->object;
                        next.startPrimitive = hit->primitive;
                        next.medium = c.medium;
                        next.depth = br.depth + 1;
                        stack.push_back(next);
                    };
                    if (options.split) {
                        for (int c = 0; c < in.count; ++c) {
                            const InteractionChild& child = in.children[c];
                            if (child.scatter || !(child.share > 0.0)) continue;
                            const double weight = br.weight * child.share;
                            if (weight < options.minRelativeWeight * start) continue;
                            push(child, weight);
                        }
                    } else {
                        // One specular child, chosen by weight, carries their sum.
                        const double x = rng.uniform() * specular;
                        double sum = 0.0;
                        int chosen = -1;
                        for (int c = 0; c < in.count; ++c) {
                            if (in.children[c].scatter) continue;
                            chosen = c;
                            sum += in.children[c].share;
                            if (x < sum) break;
                        }
                        push(in.children[chosen], br.weight * specular);
                    }
                }
                po.visible[k] = seen;
            }
        }
    });

    BackwardResult result;
    result.visible = DetectorImage(detector.geometry());
    for (int p = 0; p < pixels; ++p) {
        PixelOutput& po = out[static_cast<size_t>(p)];
        for (double v : po.visible)
            if (v != 0.0) result.visible.add(p, v);
        result.viewPoints.insert(result.viewPoints.end(), po.viewPoints.begin(),
                                 po.viewPoints.end());
        result.segments += po.segments;
    }
    result.rays = static_cast<uint64_t>(pixels) * perPixel;
    return result;
}

}  // namespace veil
