#pragma once
// Critical and illuminated objects: which parts of a scene the sources light and which the
// detector sees, and the parts in both paths, ranked: the objects to blacken or baffle first.
//
//   lit(o)   the flux arriving on object o along specular paths from the sources (refraction,
//            mirror and Fresnel reflection, TIR: no scatter before it), over the flux the
//            sources emit; every arrival counts, so a part hit twice counts twice
//   seen(o)  the same for a Lambertian emitter laid on the detector's sensitive side: the
//            share of the detector's importance (its etendue, through the lens and the
//            ghost reflections) that lands on o. By reciprocity, a detector that counts flux
//            from every direction is exactly such an emitter traced backward. The emitter is
//            the detector's grid, a hair in front of its object; rays from grid points off
//            the object (the corners of a round sensor's square grid) do not count.
//   product  sum over the sides of o of lit(side) * seen(side): light that lands on one
//            side of a part and a view of the other side give nothing. The sides of a mesh
//            are its triangles' facing (toward -z, toward +z, toward the axis: the bore, away
//            from it: the outside); an exact face's two sides are the media it separates.
//            A part that can pass light (glass faces, butt ends, flats) multiplies its
//            totals instead: what lands on one side may leave from the other.
//   scattered  of lit(o), the share o's finish scatters (the flux of the branches that
//            leave its scatter events)
//   estimate sum over the sides of scattered(side) * seen(side) * A_detector / A_side: the
//            first-order scatter reaching the detector per emitted flux, exact for a
//            Lambertian side whose light and view are spread evenly over it (for such a
//            side the detector gets (rho/pi) E * Omega A = rho lit seen A_det / A_side of
//            the emitted flux, with E the irradiance and Omega the projected solid angle
//            of the detector from it)
//
// The product ranks by geometry alone: where a finish would matter. The estimate ranks by
// what the scene's finishes do, but it does not know where on a side the light lands and
// where the view falls: on the 6-lens example it is within a factor 0.4 to 3.3 of the traced
// first scatter for most parts, and low by 20 to 30 for parts lit and seen at grazing spots.
// Once the parts to look at are known, `veil trace --where 'scatter(PART)'` or `veil render`
// gives the stray light.
//
// Both passes are the forward tracer with histories (online pruning culls a branch at its
// first scatter event), with fixed seeds: the source pass uses seed, the detector pass
// seed + 1. Errors are one sigma from the spread of the per-ray values; sums are reduced in
// ray order, so every thread count gives the same numbers.
//
// The polished optical faces (lens faces, mirrors) are lit and seen by design: they are
// listed apart, unranked, unless includeOptical.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "analysis/pictures/picture.h"
#include "analysis/reports/progress.h"
#include "analysis/reports/report_table.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

class PreparedScene;

struct ObjectsSpec {
    uint64_t rays = 0;  // per source in the source pass, and from the detector
    TransportOptions transport;
    std::string source;    // only this [[source]]; empty: all of them
    std::string detector;  // the detector whose view counts; empty: the first
    bool includeOptical = false;
    // What ranks: lit x seen (the geometry alone, whatever the finishes), or the first-order
    // estimate (the scene's finishes and the sides' areas).
    enum class Rank { Product, Estimate };
    Rank rank = Rank::Product;
    // The rays done in each pass, from one thread (may be empty): "objects: lit by the
    // sources", then "objects: seen by the detector".
    ProgressSink progress;
};

// One side of an object (see the header comment) and what arrives on it.
struct ObjectSide {
    std::string name;  // "front (-z)", "back (+z)", "bore", "outside", "from air", "from N-BK7"
    double lit = 0.0, litError = 0.0;
    double scattered = 0.0, scatteredError = 0.0;
    double seen = 0.0, seenError = 0.0;
    double areaMm2 = 0.0;
};

struct ObjectRow {
    int object = -1;
    std::string name, part, kind;
    bool optical = false;  // a lens face or a mirror
    int rank = 0;          // 1 = first to treat; 0 = not ranked (optical, or product 0)
    double lit = 0.0, litError = 0.0;
    double scattered = 0.0, scatteredError = 0.0;  // of the lit light, what its finish scatters
    double seen = 0.0, seenError = 0.0;
    double product = 0.0, productError = 0.0;
    double scatterProduct = 0.0, scatterProductError = 0.0;  // scattered x seen, by side
    // scattered x seen x detector area / side area, by side: the first-order scatter on the
    // detector per emitted flux if the light and the view were spread evenly over each side
    double estimate = 0.0, estimateError = 0.0;
    std::vector<ObjectSide> sides;  // those with anything lit or seen, by product
};

struct ObjectsResult {
    std::vector<ObjectRow> rows;  // ranked first (by rank), then the rest by product, seen, lit
    std::string detector;
    std::vector<std::string> sources;
    std::string rankedBy;  // "product" or "estimate"
    uint64_t sourceRays = 0, detectorRays = 0;
    double detectorAreaMm2 = 0.0;  // where the detector records: its grid on its object
    double seconds = 0.0;

    // One row per object (analysis/reports/report_table.h); every format is written from it.
    ReportTable table() const;
    std::string csv() const;
    std::string markdown() const;
    std::string json() const;
};

// Throws ParseError naming --source or --detector when they name nothing, ModelError when the
// scene has no source or no detector, before the first ray.
ObjectsResult runObjects(const PreparedScene& scene, const ObjectsSpec& spec);

// The layout with the `top` first ranked objects coloured by rank (dark red first) and
// numbered, the rest as in `veil layout`.
Picture drawObjects(const PreparedScene& scene, const ObjectsResult& result, int top);

}  // namespace veil
