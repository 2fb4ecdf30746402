#include "analysis/ghosts/ghost_tracer.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <numbers>
#include <sstream>

#include "analysis/lens/first_order.h"
#include "analysis/reports/format.h"
#include "geometry/lens_solid.h"
#include "geometry/mechanics.h"
#include "geometry/numerics.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/light/spectrum.h"
#include "tracer/records/detector.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/fresnel.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const GhostOptions& o) {
    return os << "GhostOptions{order " << o.order << ", grid " << o.gridRays << ", min R^4 "
              << o.minFourthOrderReflectance << ", near focus " << o.nearFocusMm << " mm}";
}

std::ostream& operator<<(std::ostream& os, const GhostSourceResult& r) {
    return os << "GhostSourceResult{" << r.source << ": flux " << r.flux << " (" << r.relativeFlux
              << " of nominal), focus " << r.focusMm << " mm, footprint " << r.footprintMm
              << " mm, peak " << r.peakIrradiance << " /mm^2}";
}

int GhostTracer::mirrorReflections(const GhostPath& path) const {
    int m = 0;
    for (const Step& st : steps(path)) m += st.reflect && model_.surface(st.surface).mirror;
    return m;
}

double GhostEstimate::flux() const {
    double f = 0.0;
    for (const GhostSourceResult& s : sources) f += s.flux;
    return f;
}
double GhostEstimate::relativeFlux() const {
    return nominalFlux > 0.0 ? flux() / nominalFlux : 0.0;
}
double GhostEstimate::peakIrradiance() const {
    double p = 0.0;
    for (const GhostSourceResult& s : sources) p = std::max(p, s.peakIrradiance);
    return p;
}
double GhostEstimate::relativeIrradiance() const {
    double p = 0.0;
    for (const GhostSourceResult& s : sources) p = std::max(p, s.relativeIrradiance);
    return p;
}
bool GhostEstimate::nearFocus() const {
    return std::any_of(sources.begin(), sources.end(),
                       [](const GhostSourceResult& s) { return s.nearFocus; });
}
std::string GhostEstimate::glassFocus() const {
    for (const GhostSourceResult& s : sources)
        if (!s.glassFocus.empty()) return s.glassFocus;
    return {};
}

// GhostTracer

GhostTracer::GhostTracer(const SceneGeometry& setup, const SceneTransport& trace,
                         const GlassCatalog& catalog, const GhostOptions& options)
    : setup_(&setup),
      trace_(&trace),
      model_(setup.model ? *setup.model : SequentialModel::build(setup.prescription, catalog)),
      options_(options) {
    if (options_.order != 2 && options_.order != 4)
        throw ModelError("ghosts",
                         "ghost order must be 2 or 4, not " + std::to_string(options_.order));
    if (options_.gridRays < 2)
        throw ModelError("ghosts", "the ray grid needs at least 2 rays across the beam");
    if (setup.detectors.empty()) throw ModelError("ghosts", "the scene has no detector");
    detectorIndex_ = 0;
    if (!options_.detector.empty()) {
        detectorIndex_ = -1;
        for (size_t d = 0; d < setup.detectors.size(); ++d)
            if (setup.detectors[d].name == options_.detector) detectorIndex_ = static_cast<int>(d);
        if (detectorIndex_ < 0)
            throw ModelError(options_.detector, "no detector named '" + options_.detector + "'");
    }
    detector_ = &setup.detectors[detectorIndex_];
    if (setup.scene.object(detector_->object).sequentialSurface != model_.imageIndex())
        throw ModelError(detector_->name,
                         "the ghost estimate follows the sequential path to the image surface; "
                         "detector '" +
                             detector_->name + "' does not lie on it");
    for (const Source& s : trace.view.sources)
        if (std::holds_alternative<WindowSource>(s.shape()) ||
            std::holds_alternative<LambertianSource>(s.shape()))
            throw ModelError(s.name(), std::string("source '") + s.name() + "' is a " + s.kind() +
                                           " source; the sequential ghost estimate needs "
                                           "collimated, sun or point sources (use --field)");

    ghostSurfaces_ = ghostSurfaces(model_);
    const int n = model_.surfaceCount();
    clipRadius_.assign(n, kInfinity);
    holeRadius_.assign(n, 0.0);
    propertyOf_.assign(n, -1);
    objectName_.assign(n, "");
    const Prescription& p = setup.prescription;
    std::map<int, double> faceRadius;
    for (const LensSolid& s : lensSolids(p)) {
        faceRadius[s.front.surface] = s.front.faceRadiusMm;
        faceRadius[s.back.surface] = s.back.faceRadiusMm;
    }
    const SceneObject* stopPlate = setup.scene.find("stop");
    for (int s = 1; s < model_.imageIndex(); ++s) {
        const Surface& sf = p.surfaces[s];
        const SceneObject* o = sf.name.empty() ? nullptr : setup.scene.find(sf.name);
        if (o && o->kind != ObjectKind::Stop && o->kind != ObjectKind::Mechanics) {
            objectName_[s] = o->name;
            propertyOf_[s] = trace.view.propertyOfObject[o->id];
        }
        if (auto it = faceRadius.find(s); it != faceRadius.end()) {
            clipRadius_[s] = it->second;
        } else if (sf.mirror || (o && o->kind == ObjectKind::LensFace)) {
            if (sf.clearSemiDiameterMm > 0.0) clipRadius_[s] = sf.clearSemiDiameterMm;
        } else if (sf.stop && stopPlate && sf.clearSemiDiameterMm > 0.0) {
            clipRadius_[s] = sf.clearSemiDiameterMm;
        }
        holeRadius_[s] = sf.innerSemiDiameterMm;
        if (sf.mirror && std::isfinite(clipRadius_[s])) mirrors_.push_back(s);
    }
    // Light that fills surface 1 can pass beside the first lens when something (a stop, an
    // aperture ring) comes before it; the sequential path goes through the lens.
    if (!ghostSurfaces_.empty() && ghostSurfaces_.front() != 1 &&
        !objectName_[ghostSurfaces_.front()].empty())
        firstFace_ = objectName_[ghostSurfaces_.front()];
    mediumOfGap_.assign(n, 0);
    for (int g = 0; g < n; ++g) {
        const Material& m = p.surfaces[g].material;
        const auto& media = setup.scene.media();
        for (size_t k = 0; k < media.size(); ++k)
            if (media[k].material == m) mediumOfGap_[g] = static_cast<int>(k);
    }
    // Flux of one grid cell per source and wavelength: the source's share of that line over
    // the cells of the unit disk (cell area h^2 of pi).
    const double h = 2.0 / options_.gridRays;
    cellFlux_.assign(trace.view.sources.size(), std::vector<double>(model_.wavelengthCount()));
    for (size_t k = 0; k < cellFlux_.size(); ++k)
        for (int w = 0; w < model_.wavelengthCount(); ++w)
            cellFlux_[k][w] =
                trace.view.sources[k].totalFlux() * lineShare(static_cast<int>(k), w) * h * h / kPi;
    if (options_.nearFocusMm <= 0.0)
        options_.nearFocusMm =
            10.0 * std::max(detector_->pixelWidthMm(), detector_->pixelHeightMm());
}

std::vector<GhostPath> GhostTracer::enumerate(int* pruned) const {
    std::vector<GhostPath> out;
    const std::string det = setup_->scene.object(detector_->object).name;
    auto make = [&](std::vector<int> refl) {
        GhostPath g;
        g.reflections = std::move(refl);
        for (int s : g.reflections)
            g.names.push_back(objectName_[s].empty() ? model_.surface(s).name : objectName_[s]);
        g.label = join(g.names, " > ");
        g.criterion = ghostCriterion(g.names, det, mirrorReflections(g), firstFace_);
        return g;
    };
    const std::vector<int>& gs = ghostSurfaces_;
    for (size_t a = 0; a < gs.size(); ++a)
        for (size_t b = 0; b < a; ++b) out.push_back(make({gs[a], gs[b]}));
    if (options_.order < 4) return out;
    // Normal-incidence reflectance of each ghost surface at the primary wavelength under its
    // optical property: the energy bound that prunes four-reflection paths.
    const int w = model_.primaryWavelength();
    std::vector<double> r0(model_.surfaceCount(), 0.0);
    for (int s : gs) {
        const double n1 = std::abs(model_.index(s - 1, w)), n2 = std::abs(model_.index(s, w));
        double r = fresnelReflectance(n1, n2, 1.0);
        if (propertyOf_[s] >= 0) {
            SurfaceContext c;
            c.direction = Vec3(0.0, 0.0, 1.0);
            c.normal = Vec3(0.0, 0.0, -1.0);
            c.n1 = n1;
            c.n2 = n2;
            c.wavelengthNm = model_.wavelengthNm(w);
            r = trace_->view.properties[propertyOf_[s]].channels(c).specularReflect;
        }
        r0[s] = r;
    }
    int cut = 0;
    for (int i : gs)
        for (int j : gs) {
            if (j >= i) continue;
            for (int k : gs) {
                if (k <= j) continue;
                for (int l : gs) {
                    if (l >= k) continue;
                    if (r0[i] * r0[j] * r0[k] * r0[l] < options_.minFourthOrderReflectance) {
                        ++cut;
                        continue;
                    }
                    out.push_back(make({i, j, k, l}));
                }
            }
        }
    if (pruned) *pruned = cut;
    return out;
}

GhostPath GhostTracer::nominalPath() const {
    GhostPath g;
    g.label = "nominal image";
    g.criterion = nominalCriterion(setup_->scene.object(detector_->object).name,
                                   mirrorReflections(g), firstFace_);
    return g;
}

std::vector<GhostTracer::Step> GhostTracer::steps(const GhostPath& path) const {
    std::vector<Step> out;
    const int image = model_.imageIndex();
    int s = 1;
    bool forward = true;
    size_t r = 0;
    while (!(forward && s == image)) {
        if (s < 1 || s >= image)
            throw ModelError(path.label,
                             "ghost path leaves the lens: reflections must alternate "
                             "between later and earlier surfaces");
        Step st;
        st.surface = s;
        st.forwardBefore = forward;
        st.gapBefore = forward ? s - 1 : s;
        if (r < path.reflections.size() && path.reflections[r] == s) {
            ++r;
            st.reflect = true;
            st.gapAfter = st.gapBefore;
            st.forwardAfter = !forward;
        } else {
            st.reflect = model_.surface(s).mirror;
            st.gapAfter = forward ? s : s - 1;
            st.forwardAfter = forward;
        }
        out.push_back(st);
        forward = st.forwardAfter;
        s += forward ? 1 : -1;
    }
    if (r != path.reflections.size())
        throw ModelError(path.label, "ghost path: reflection surfaces out of order");
    return out;
}

double GhostTracer::lineShare(int source, int w) const {
    const SpectralSampler& spec = trace_->view.sources[source].spectrum();
    double share = 0.0;
    for (int i = 0; i < spec.size(); ++i)
        if (std::abs(spec.lines()[i].nm - model_.wavelengthNm(w)) < 1e-9) share += spec.share(i);
    return share;
}

bool GhostTracer::launch(int source, int w, int ix, int iy, RayState& r) const {
    const Source& src = trace_->view.sources[source];
    r.flux = cellFlux_[source][w];
    if (!(r.flux > 0.0)) return false;
    const double h = 2.0 / options_.gridRays;  // grid step in the unit disk
    const double a = -1.0 + (ix + 0.5) * h, b = -1.0 + (iy + 0.5) * h;
    const double rr = a * a + b * b;
    if (rr > 1.0) return false;
    // The unit disk mapped to the beam's start disk or onto the point source's cone.
    const Beam* beam = nullptr;
    if (const auto* c = std::get_if<CollimatedSource>(&src.shape())) beam = &c->beam;
    if (const auto* c = std::get_if<SunSource>(&src.shape())) beam = &c->beam;
    if (beam) {
        r.pos = beam->startCenterMm + beam->radiusMm * (a * beam->axisU + b * beam->axisV);
        r.dir = beam->direction;
    } else if (const auto* point = std::get_if<PointSource>(&src.shape())) {
        // Equal-area map of the disk onto the cap: uniform in solid angle.
        const double cosT = 1.0 - rr * (1.0 - std::cos(point->halfAngleRad));
        const double sinT = std::sqrt(std::max(0.0, 1.0 - cosT * cosT));
        const double rho = std::sqrt(rr);
        const double ca = rho > 0.0 ? a / rho : 1.0, sa = rho > 0.0 ? b / rho : 0.0;
        r.pos = point->positionMm;
        r.dir = cosT * point->axis + sinT * (ca * point->axisU + sa * point->axisV);
    } else {
        return false;
    }
    return true;
}

bool GhostTracer::advance(RayState& r, const Step& step, int w) const {
    const SequentialSurface& s = model_.surface(step.surface);
    if (s.coordinateBreak) return true;  // only the frame changes
    const Ray local = s.toLocal(r.pos, r.dir);
    const std::optional<double> t = intersectSequential(s.shape, local);
    if (!t || *t < -1e-9) return false;  // missed, or behind the ray: not this path
    if (!mirrors_.empty() && obscured(r, *t, step.surface)) return false;
    const Vec3 hit = local.origin + *t * local.direction;
    // Squared radii: hypot would cost more than the intersection.
    const double r2 = hit.x * hit.x + hit.y * hit.y;
    const double clip = clipRadius_[step.surface], hole = holeRadius_[step.surface];
    if (r2 > clip * clip || r2 < hole * hole) return false;
    const double alpha = trace_->view.media->absorptionPerMm(mediumOfGap_[step.gapBefore], w);
    if (alpha > 0.0) r.flux *= std::exp(-alpha * std::max(0.0, *t));
    r.pos = s.toGlobalPoint(hit);
    r.at = step.surface;
    // The normal in global coordinates, like the ray's direction.
    Vec3 nrm = s.toGlobalDirection(surfaceNormal(s.shape, hit));
    if (glm::dot(nrm, r.dir) > 0.0) nrm = -nrm;
    const double n1 = std::abs(model_.index(step.gapBefore, w));
    // The medium across the surface: where a refracted ray goes, and the one a ghost
    // reflection does not enter (a mirror uses n1 on both sides).
    const int across = step.forwardBefore ? step.surface : step.surface - 1;
    const double n2 = std::abs(model_.index(across, w));
    const int prop = propertyOf_[step.surface];
    Channels ch;
    if (prop >= 0) {
        SurfaceContext c;
        c.direction = r.dir;
        c.normal = nrm;
        c.n1 = n1;
        c.n2 = s.mirror ? n1 : n2;
        c.wavelengthNm = model_.wavelengthNm(w);
        ch = trace_->view.properties[prop].channels(c);
    } else {
        ch.specularReflect = 1.0;  // no object: nothing happens but the geometry
        ch.specularTransmit = 1.0;
        ch.tir = !s.mirror && totalInternalReflection(n1, n2, -glm::dot(r.dir, nrm));
    }
    if (step.reflect) {
        if (ch.tir && !s.mirror) return false;  // a total reflection is not a ghost reflection
        r.flux *= ch.specularReflect;
        r.dir = reflect(r.dir, nrm);
    } else {
        if (ch.tir) return false;
        r.flux *= ch.specularTransmit;
        if (n1 != n2) {
            const std::optional<Vec3> d2 = refract(r.dir, nrm, n1, n2);
            if (!d2) return false;
            r.dir = *d2;
        }
    }
    return r.flux > 0.0;
}

bool GhostTracer::obscured(const RayState& r, double t, int target) const {
    for (int m : mirrors_) {
        if (m == r.at || m == target) continue;
        const SequentialSurface& s = model_.surface(m);
        const Ray local = s.toLocal(r.pos, r.dir);
        const std::optional<ShapeHit> h =
            intersectFirst(s.shape, local, 0.0, t, clipRadius_[m], false);
        if (!h) continue;
        const double hole = holeRadius_[m];
        if (h->point.x * h->point.x + h->point.y * h->point.y >= hole * hole) return true;
    }
    return false;
}

bool GhostTracer::land(const RayState& r, int w, DetectorRay& out) const {
    const int img = model_.imageIndex();
    const SequentialSurface& image = model_.surface(img);
    const Ray local = image.toLocal(r.pos, r.dir);
    const std::optional<double> t = intersectSequential(image.shape, local);
    if (!t || *t < -1e-9) return false;
    if (!mirrors_.empty() && obscured(r, *t, img)) return false;
    double flux = r.flux;
    const double alpha = trace_->view.media->absorptionPerMm(mediumOfGap_[img - 1], w);
    if (alpha > 0.0) flux *= std::exp(-alpha * *t);
    const Vec3 localHit = local.origin + *t * local.direction;
    // The sensor object is the image surface out to its clear semi-diameter.
    const double imageSd = model_.prescription().surfaces[img].clearSemiDiameterMm;
    if (imageSd > 0.0 && localHit.x * localHit.x + localHit.y * localHit.y > imageSd * imageSd)
        return false;
    const Vec3 q = detector_->frame.toLocalPoint(image.toGlobalPoint(localHit));
    if (std::abs(q.x) > 0.5 * detector_->widthMm || std::abs(q.y) > 0.5 * detector_->heightMm)
        return false;
    out = {Vec2(q.x, q.y), flux};
    return true;
}

double GhostTracer::backwardIrradiance(const GhostPath& path, Vec2 imagePointMm, int w,
                                       const std::function<double(const Vec3&)>& radiance,
                                       int gridSide) const {
    // The path reversed: the same surfaces in the opposite order, each step's sides swapped.
    std::vector<Step> st = steps(path);
    std::reverse(st.begin(), st.end());
    for (Step& step : st) {
        std::swap(step.gapBefore, step.gapAfter);
        const bool before = step.forwardBefore;
        step.forwardBefore = !step.forwardAfter;
        step.forwardAfter = !before;
    }
    const int img = model_.imageIndex();
    const SequentialSurface& image = model_.surface(img);
    const Vec3 x = image.toGlobalPoint(Vec3(imagePointMm.x, imagePointMm.y, 0.0));
    const Vec3 imageNormal = image.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    // The grid: a disk on the vertex plane of the last surface before the image, as wide as
    // what the surface lets through.
    const int last = img - 1;
    const SequentialSurface& ls = model_.surface(last);
    const Surface& lp = model_.prescription().surfaces[static_cast<size_t>(last)];
    double radius = clipRadius_[last];
    if (!std::isfinite(radius))
        radius = std::max(lp.mechSemiDiameterMm, lp.clearSemiDiameterMm) * 1.5;
    if (!(radius > 0.0)) return 0.0;
    const Vec3 planeNormal = ls.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    const double h = 2.0 / gridSide;
    const double cellArea = (h * radius) * (h * radius);
    double sum = 0.0;
    uint64_t count = 0;
    for (int iy = 0; iy < gridSide; ++iy)
        for (int ix = 0; ix < gridSide; ++ix) {
            const double a = -1.0 + (ix + 0.5) * h, b = -1.0 + (iy + 0.5) * h;
            if (a * a + b * b > 1.0) continue;
            const Vec3 target = ls.toGlobalPoint(Vec3(a * radius, b * radius, 0.0));
            const Vec3 d = target - x;
            const double dist = glm::length(d);
            if (!(dist > 0.0)) continue;
            RayState r;
            r.pos = x;
            r.dir = d / dist;
            r.flux = 1.0;
            r.at = img;
            // Projected solid angle at the point of this cell of the plane.
            const double weight = cellArea * std::abs(glm::dot(r.dir, planeNormal)) *
                                  std::abs(glm::dot(r.dir, imageNormal)) / (dist * dist);
            bool alive = true;
            for (const Step& step : st) {
                ++count;
                if (!(alive = advance(r, step, w))) break;
            }
            if (!alive) continue;
            const double l = radiance(-r.dir);
            if (l > 0.0) sum += weight * r.flux * l;
        }
    steps_ += count;
    return sum;
}

std::vector<std::pair<Ray, int>> GhostTracer::gridRays(int source) const {
    std::vector<std::pair<Ray, int>> out;
    for (int w = 0; w < model_.wavelengthCount(); ++w)
        for (int iy = 0; iy < options_.gridRays; ++iy)
            for (int ix = 0; ix < options_.gridRays; ++ix) {
                RayState r;
                if (launch(source, w, ix, iy, r)) out.push_back({Ray{r.pos, r.dir}, w});
            }
    return out;
}

std::vector<GhostTracer::DetectorRay> GhostTracer::traceGrid(const GhostPath& path, int source,
                                                             int w, int* traced) const {
    const std::vector<Step> st = steps(path);
    std::vector<DetectorRay> out;
    if (traced) *traced = 0;
    uint64_t steps = 0;
    const int n = options_.gridRays;
    for (int iy = 0; iy < n; ++iy)
        for (int ix = 0; ix < n; ++ix) {
            RayState r;
            if (!launch(source, w, ix, iy, r)) continue;
            if (traced) ++*traced;
            bool alive = true;
            for (const Step& step : st) {
                ++steps;
                if (!(alive = advance(r, step, w))) break;
            }
            DetectorRay d;
            if (alive && (++steps, land(r, w, d))) out.push_back(d);
        }
    steps_ += steps;
    return out;
}

std::pair<double, std::string> GhostTracer::paraxialFocus(const GhostPath& path, int source) const {
    const std::vector<Step> st = steps(path);
    const int w = model_.primaryWavelength();
    const Source& src = trace_->view.sources[source];
    const Prescription& p = model_.prescription();
    double y = 1.0, u = 0.0;  // collimated: height 1 mm, slope 0
    double z = model_.surface(1).zMm;
    if (const auto* ps = std::get_if<PointSource>(&src.shape())) {
        u = 1e-3;
        y = u * (z - ps->positionMm.z);
    }
    std::string glass;
    auto signedIndex = [&](int gap, bool forward) {
        return (forward ? 1.0 : -1.0) * model_.index(gap, w);
    };
    for (size_t k = 0; k < st.size(); ++k) {
        const Step& step = st[k];
        const SequentialSurface& s = model_.surface(step.surface);
        const double y2 = y + u * (s.zMm - z);
        if (k > 0 && glass.empty() && y * y2 < 0.0 &&
            !p.surfaces[step.gapBefore].material.isAir()) {
            const double f = y / (y - y2);
            std::ostringstream os;
            os.precision(4);
            os << p.surfaces[step.gapBefore].material.label() << " between "
               << model_.surface(st[k - 1].surface).name << " and " << s.name << " (z "
               << (z + f * (s.zMm - z)) << " mm)";
            glass = os.str();
        }
        y = y2;
        z = s.zMm;
        const double nBefore = signedIndex(step.gapBefore, step.forwardBefore);
        const double nAfter = signedIndex(step.gapAfter, step.forwardAfter);
        const double c = paraxialCurvature(p.surfaces[step.surface]);
        const double nu = nBefore * u - y * c * (nAfter - nBefore);
        u = nu / nAfter;
    }
    const double zImage = model_.surface(model_.imageIndex()).zMm;
    if (std::abs(u) < 1e-15) return {kInfinity, glass};
    const double zFocus = z - y / u;
    return {zFocus - zImage, glass};
}

GhostSourceResult GhostTracer::summarise(const GhostPath& path, int source,
                                         const std::vector<DetectorRay>& rays, int raysTraced,
                                         const GhostEstimate* nominal) const {
    const double pitch = std::max(detector_->pixelWidthMm(), detector_->pixelHeightMm());
    GhostSourceResult r;
    r.source = trace_->view.sources[source].name();
    r.raysTraced = raysTraced;
    r.raysArrived = static_cast<int>(rays.size());
    for (const DetectorRay& d : rays) {
        r.flux += d.flux;
        r.centroidMm += d.flux * d.xyMm;
    }
    if (r.flux > 0.0) {
        r.centroidMm /= r.flux;
        double rmax = 0.0;
        for (const DetectorRay& d : rays) rmax = std::max(rmax, glm::length(d.xyMm - r.centroidMm));
        r.footprintMm = 2.0 * rmax;
        const double bin = std::max(pitch, r.footprintMm / 16.0);
        std::map<std::pair<long, long>, double> bins;
        for (const DetectorRay& d : rays) {
            const Vec2 q = (d.xyMm - r.centroidMm) / bin;
            bins[{std::lround(q.x), std::lround(q.y)}] += d.flux;
        }
        double peak = 0.0;
        for (const auto& [key, f] : bins) peak = std::max(peak, f);
        r.peakIrradiance = peak / (bin * bin);
    }
    const auto [focus, glass] = paraxialFocus(path, source);
    r.focusMm = focus;
    r.glassFocus = glass;
    r.nearFocus = r.flux > 0.0 && r.footprintMm <= options_.nearFocusMm;
    if (nominal && static_cast<size_t>(source) < nominal->sources.size()) {
        const GhostSourceResult& n = nominal->sources[source];
        r.relativeFlux = n.flux > 0.0 ? r.flux / n.flux : 0.0;
        r.relativeIrradiance = n.peakIrradiance > 0.0 ? r.peakIrradiance / n.peakIrradiance : 0.0;
    } else {
        r.relativeFlux = r.flux > 0.0 ? 1.0 : 0.0;
        r.relativeIrradiance = r.peakIrradiance > 0.0 ? 1.0 : 0.0;
    }
    return r;
}

GhostEstimate GhostTracer::estimate(const GhostPath& path, const GhostEstimate* nominal) const {
    GhostEstimate e;
    e.path = path;
    for (size_t s = 0; s < trace_->view.sources.size(); ++s) {
        std::vector<DetectorRay> rays;
        int traced = 0;
        for (int w = 0; w < model_.wavelengthCount(); ++w) {
            int t = 0;
            const std::vector<DetectorRay> part = traceGrid(path, static_cast<int>(s), w, &t);
            traced += t;
            rays.insert(rays.end(), part.begin(), part.end());
        }
        e.sources.push_back(summarise(path, static_cast<int>(s), rays, traced, nominal));
    }
    e.nominalFlux = nominal ? nominal->flux() : e.flux();
    return e;
}

std::vector<GhostEstimate> GhostTracer::estimatePairs(const std::vector<GhostPath>& paths,
                                                      const GhostEstimate* nominal) const {
    // Two-reflection paths share their beginnings: every ray is traced forward once, from each
    // first reflection i backward once, and from each second reflection j forward to the
    // detector. The same steps in the same order as traceGrid, so the same numbers.
    const int image = model_.imageIndex();
    // pathOf[i * image + j]: the path reflecting at i then j, or -1; firstSurface[i]: some
    // path reflects first at i.
    std::vector<int> pathOf(static_cast<size_t>(image) * image, -1);
    std::vector<bool> firstSurface(image, false);
    for (size_t g = 0; g < paths.size(); ++g) {
        if (paths[g].order() != 2)
            throw ModelError(paths[g].label, "estimatePairs takes two-reflection paths only");
        const int i = paths[g].reflections[0], j = paths[g].reflections[1];
        pathOf[static_cast<size_t>(i) * image + j] = static_cast<int>(g);
        firstSurface[i] = true;
    }
    auto nominalStep = [&](int s, bool forward) {
        Step st;
        st.surface = s;
        st.forwardBefore = st.forwardAfter = forward;
        st.gapBefore = forward ? s - 1 : s;
        st.gapAfter = forward ? s : s - 1;
        st.reflect = model_.surface(s).mirror;
        return st;
    };
    auto ghostStep = [&](int s, bool forward) {
        Step st;
        st.surface = s;
        st.forwardBefore = forward;
        st.forwardAfter = !forward;
        st.gapBefore = st.gapAfter = forward ? s - 1 : s;
        st.reflect = true;
        return st;
    };
    const size_t nSources = trace_->view.sources.size();
    std::vector<GhostEstimate> out(paths.size());
    for (GhostEstimate& e : out) e.sources.resize(nSources);
    // Sources are independent: one task each (the numbers do not depend on the threads).
    tbb::parallel_for(size_t(0), nSources, [&](size_t s) {
        std::vector<std::vector<DetectorRay>> rays(paths.size());
        std::vector<RayState> arriving(image);  // forward, arriving at surface k
        int traced = 0;
        uint64_t steps = 0;
        auto step = [&](RayState& r, const Step& st, int w) {
            ++steps;
            return advance(r, st, w);
        };
        for (int w = 0; w < model_.wavelengthCount(); ++w) {
            const int n = options_.gridRays;
            for (int iy = 0; iy < n; ++iy)
                for (int ix = 0; ix < n; ++ix) {
                    RayState r;
                    if (!launch(static_cast<int>(s), w, ix, iy, r)) continue;
                    ++traced;
                    int reached = 0;  // the ray arrived at surfaces 1..reached
                    for (int k = 1; k < image; ++k) {
                        arriving[k] = r;
                        reached = k;
                        if (!step(r, nominalStep(k, true), w)) break;
                    }
                    for (int i = 1; i <= reached; ++i) {
                        if (!firstSurface[i]) continue;
                        RayState b = arriving[i];
                        if (!step(b, ghostStep(i, true), w)) continue;
                        for (int k = i - 1; k >= 1; --k) {
                            if (const int g = pathOf[static_cast<size_t>(i) * image + k]; g >= 0) {
                                RayState f = b;
                                bool alive = step(f, ghostStep(k, false), w);
                                for (int m = k + 1; alive && m < image; ++m)
                                    alive = step(f, nominalStep(m, true), w);
                                DetectorRay d;
                                if (alive && (++steps, land(f, w, d))) rays[g].push_back(d);
                            }
                            if (!step(b, nominalStep(k, false), w)) break;
                        }
                    }
                }
        }
        steps_ += steps;
        for (size_t g = 0; g < paths.size(); ++g)
            out[g].sources[s] = summarise(paths[g], static_cast<int>(s), rays[g], traced, nominal);
    });
    for (size_t g = 0; g < paths.size(); ++g) {
        out[g].path = paths[g];
        out[g].nominalFlux = nominal ? nominal->flux() : out[g].flux();
    }
    return out;
}

GhostAnalysis GhostTracer::analyse() const {
    const auto start = std::chrono::steady_clock::now();
    const uint64_t steps0 = steps_;
    GhostAnalysis a;
    a.surfaces = ghostSurfaces_;
    for (int s : ghostSurfaces_)
        a.surfaceNames.push_back(objectName_[s].empty() ? model_.surface(s).name : objectName_[s]);
    a.detector = detector_->name;
    a.nominal = estimate(nominalPath(), nullptr);
    std::vector<GhostPath> pairs, others;
    for (GhostPath& g : enumerate(&a.pruned))
        (g.order() == 2 ? pairs : others).push_back(std::move(g));
    a.ghosts = estimatePairs(pairs, &a.nominal);
    for (const GhostPath& g : others) a.ghosts.push_back(estimate(g, &a.nominal));
    // All ghosts together: one count of Fresnel reflections when no mirror is crossed (or
    // when there is no ghost: a system of mirrors alone), else the ghosts' own criteria
    // (their mirror counts differ).
    int maxOrder = 2;
    bool mirrors = mirrorReflections(nominalPath()) > 0;
    for (const GhostEstimate& g : a.ghosts) maxOrder = std::max(maxOrder, g.path.order());
    if (!mirrors || a.ghosts.empty()) {
        a.allGhostsCriterion =
            allGhostsCriterion(maxOrder, setup_->scene.object(detector_->object).name, firstFace_);
    } else {
        std::vector<std::string> each;
        for (const GhostEstimate& g : a.ghosts) each.push_back("(" + g.path.criterion + ")");
        a.allGhostsCriterion = join(each, " or ");
    }
    std::stable_sort(a.ghosts.begin(), a.ghosts.end(),
                     [](const GhostEstimate& x, const GhostEstimate& y) {
                         return x.peakIrradiance() > y.peakIrradiance();
                     });
    a.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    a.raySurfaceSteps = steps_ - steps0;
    return a;
}

}  // namespace veil
