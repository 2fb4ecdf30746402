#include "analysis/studies/glare.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/lens/first_order.h"
#include "analysis/reports/format.h"
#include "analysis/runs/render_run.h"
#include "geometry/exact_face.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/light/source.h"
#include "tracer/light/spectrum.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// The mean of the passes' values and its standard error.
GlareValue meanOf(const std::vector<double>& x) {
    GlareValue g;
    const double n = static_cast<double>(x.size());
    if (x.empty()) return g;
    double sum = 0.0;
    for (double v : x) sum += v;
    g.value = sum / n;
    if (x.size() < 2) return g;
    double ss = 0.0;
    for (double v : x) ss += (v - g.value) * (v - g.value);
    g.error = std::sqrt(ss / (n * (n - 1.0)));
    return g;
}

// Where the spot's chief ray meets the image surface (local x, y), at the primary wavelength.
std::optional<Vec2> chiefImage(const SequentialModel& model, const RayAimer& aimer, Vec2 fieldDeg) {
    const int w = model.primaryWavelength();
    const AimedRay chief = aimer.aim(fieldDeg.x, fieldDeg.y, 0.0, 0.0, w);
    if (chief.status != RayStatus::Ok) return std::nullopt;
    SequentialTraceOptions o;
    o.clipApertures = false;
    const SequentialRayResult r = traceSequential(model, w, chief.ray, o);
    if (!r.ok()) return std::nullopt;
    const Vec3 q = model.localPoint(r.surface, r.ray.origin);
    return Vec2(q.x, q.y);
}

// The lens's wavelengths and weights as the field's spectrum: photometric when the eye sees
// every line, else radiometric.
SpectralSampler fieldSpectrum(const SceneSpec& file, std::string& described, std::string& unit) {
    const SequentialModel& model = *file.model;
    const auto& waves = file.prescription.system.wavelengths;
    std::vector<Wavelength> lines;
    bool visible = true;
    for (int i = 0; i < model.wavelengthCount(); ++i) {
        const double nm = model.wavelengthNm(i);
        lines.push_back({nm, static_cast<int>(waves.size()) == model.wavelengthCount()
                                 ? waves[static_cast<size_t>(i)].weight
                                 : 1.0});
        visible = visible && photopicEfficiency(nm) > 0.0;
    }
    std::ostringstream os;
    for (size_t i = 0; i < lines.size(); ++i)
        os << (i ? ", " : "") << significant(lines[i].nm, 6) << " nm (weight "
           << significant(lines[i].weight, 4) << ")";
    if (visible) {
        described = "photometric: the lens's wavelengths " + os.str() + ", times V(lambda)";
        unit = "lm";
        return SpectralSampler(lines, FluxUnit::Lumen, SpectralSampling::Photometric,
                               "glare field");
    }
    described = "radiometric: the lens's wavelengths " + os.str() +
                " (a line outside 360-830 nm: no photometric weighting)";
    unit = "W";
    return SpectralSampler(lines, FluxUnit::Watt, SpectralSampling::Radiometric, "glare field");
}

struct SceneExtent {
    double frontZMm = 0.0, backZMm = 0.0;  // z range of everything but the detectors
    double radiusMm = 0.0;                 // largest distance from the axis
};

SceneExtent extentOf(const PreparedScene& p) {
    SceneExtent e;
    Bounds3 b;
    const Scene& scene = p.scene();
    for (const SceneObject& o : scene.objects()) {
        if (o.kind == ObjectKind::Detector) continue;
        if (const auto* f = std::get_if<FaceGeometry>(&o.geometry))
            b.extend(transformBounds(o.frame, faceBounds(*f)));
        else
            b.extend(
                scene.meshes()[static_cast<size_t>(std::get<MeshRef>(o.geometry).mesh)].bounds());
    }
    if (b.empty()) return e;
    e.frontZMm = b.lo.z;
    e.backZMm = b.hi.z;
    e.radiusMm = std::hypot(std::max(std::abs(b.lo.x), std::abs(b.hi.x)),
                            std::max(std::abs(b.lo.y), std::abs(b.hi.y)));
    return e;
}

}  // namespace

double spreadRadius(double lo, double hi) { return lo > 0.0 ? std::sqrt(lo * hi) : 0.5 * hi; }

GlareValue ratio(const GlareValue& a, const GlareValue& b) {
    GlareValue r;
    if (!(b.value > 0.0)) return r;
    r.value = a.value / b.value;
    const double ea = a.error / b.value;
    const double eb = a.value * b.error / (b.value * b.value);
    r.error = std::sqrt(ea * ea + eb * eb);
    return r;
}

// Glare Bench

GlareBench::GlareBench(const SceneSpec& file, const GlassCatalog& catalog, const GlareSpec& spec)
    : file_(file), spec_(spec), aimer_(std::make_unique<RayAimer>(*file.model)) {
    const SequentialModel& model = *file.model;
    if (file.prescription.system.fieldKind != SystemData::FieldKind::AngleDeg)
        throw ModelError(file.path.string(),
                         "veil glare needs a lens that images from infinity (fields as angles): "
                         "the veiling glare index is defined for a field at infinity");
    if (!(spec.spotDiameterDeg > 0.0 && spec.spotDiameterDeg < 20.0))
        throw ModelError("--spot-deg", "the black spot's diameter must lie in (0, 20) degrees");
    if (!(spec.fieldHalfAngleDeg > 0.0 && spec.fieldHalfAngleDeg <= 89.0))
        throw ModelError("--field-deg",
                         "the bright field's half angle must lie in (0, 89] degrees");
    spectrum_ = std::make_unique<SpectralSampler>(fieldSpectrum(file, spectrumText_, unit_));

    // The camera body the measurement puts the lens in: an absorbing box of revolution around
    // the lens and its mechanics, open in front as wide as the first surface (mechanical
    // semi-diameter: the sphere's port) and behind as wide as the last surface before the
    // image, so that light reaches the image only through the lens's front and out of its
    // back, as it does in the camera. The field is a window just in front of the port, wide
    // enough that every point of the port sees the whole cone; the front plate reaches past
    // the window, so no ray of the field passes outside it.
    SceneSpec bare = file;
    bare.sources.clear();
    const SceneExtent extent = extentOf(*PreparedScene::build(bare, catalog));
    const EntranceAperture entrance = entranceAperture(file.prescription, model);
    const double portRadiusMm = entrance.radiusMm > 0.0 ? entrance.radiusMm : extent.radiusMm;
    const Surface& last = file.prescription.surfaces[static_cast<size_t>(model.imageIndex() - 1)];
    double backRadiusMm =
        last.mechSemiDiameterMm > 0.0 ? last.mechSemiDiameterMm : last.clearSemiDiameterMm;
    if (!(backRadiusMm > 0.0)) backRadiusMm = extent.radiusMm;
    const double gapMm = 0.5, wallMm = 1.0;
    const double frontBackZ = extent.frontZMm - gapMm, frontFrontZ = frontBackZ - wallMm;
    const double rearFrontZ = extent.backZMm + gapMm, rearBackZ = rearFrontZ + wallMm;
    const double tubeInnerMm = std::max({extent.radiusMm, portRadiusMm, backRadiusMm}) + gapMm;
    const double tubeOuterMm = tubeInnerMm + wallMm;
    const double cone = spec.fieldHalfAngleDeg * kDeg;
    portRadiusMm_ = portRadiusMm;
    portFrontZMm_ = frontFrontZ;
    portBackZMm_ = frontBackZ;
    windowZMm_ = frontFrontZ - gapMm;
    windowRadiusMm_ = portRadiusMm + (frontBackZ - windowZMm_) * std::tan(cone) + 1.0;
    const double plateOuterMm = std::max(windowRadiusMm_, tubeOuterMm) + 1.0;
    MechanicsSpec::Part body;
    body.name = "glare_body";
    body.property = "absorber";
    body.profileMm = {{portRadiusMm, frontFrontZ}, {plateOuterMm, frontFrontZ},
                      {plateOuterMm, frontBackZ},  {tubeOuterMm, frontBackZ},
                      {tubeOuterMm, rearBackZ},    {backRadiusMm, rearBackZ},
                      {backRadiusMm, rearFrontZ},  {tubeInnerMm, rearFrontZ},
                      {tubeInnerMm, frontBackZ},   {portRadiusMm, frontBackZ}};
    double area2 = 0.0;  // twice the signed area in (r, z): counter-clockwise is positive
    for (size_t i = 0; i < body.profileMm.size(); ++i) {
        const Vec2 a = body.profileMm[i], b = body.profileMm[(i + 1) % body.profileMm.size()];
        area2 += a.x * b.y - b.x * a.y;
    }
    if (area2 < 0.0) std::reverse(body.profileMm.begin(), body.profileMm.end());
    if (!file_.mechanics) {
        MechanicsSpec m;
        m.barrel.enabled = m.retainers.enabled = m.spacers.enabled = m.stop.enabled = false;
        file_.mechanics = m;
    }
    file_.mechanics->parts.push_back(body);
    radiusHintMm_ = 0.01 * std::max(1.0, 2.0 * extent.radiusMm);

    SceneSpec lens = file_;
    const Beam beam = beamFillingAperture(entrance, Vec3(0.0, 0.0, 1.0), {});
    lens.sources = {Source("axis", CollimatedSource{beam}, beam.areaMm2(), *spectrum_)};
    lens.detectors.clear();
    ghostScene_ = PreparedScene::build(std::move(lens), catalog);
    ghostTracer_ =
        std::make_unique<GhostTracer>(ghostScene_->geometry(), ghostScene_->transport(), catalog);
}

GlareBench::~GlareBench() = default;

GlareField GlareBench::locate(Vec2 fieldDeg) const {
    const SequentialModel& model = *file_.model;
    GlareField gf;
    gf.fieldDeg = fieldDeg;
    const double spotRadius = 0.5 * spec_.spotDiameterDeg;
    const Vec3 axis = fieldDirection(fieldDeg.x, fieldDeg.y);
    const std::string name =
        "field " + significant(fieldDeg.x, 4) + "," + significant(fieldDeg.y, 4);
    if (std::acos(std::clamp(axis.z, -1.0, 1.0)) / kDeg + spotRadius > spec_.fieldHalfAngleDeg)
        throw ModelError(name, "the black spot reaches past the bright field (--field-deg " +
                                   significant(spec_.fieldHalfAngleDeg, 4) + ")");
    const auto centre = chiefImage(model, *aimer_, fieldDeg);
    if (!centre) throw ModelError(name, "no real chief ray reaches the image from this direction");
    gf.imageMm = *centre;
    // The spot's image radius: the chief ray's image moves this far for the spot's angular
    // radius, the least over four directions about the spot's centre.
    double r = std::numeric_limits<double>::infinity();
    for (const Vec2 d : {Vec2(1, 0), Vec2(-1, 0), Vec2(0, 1), Vec2(0, -1)})
        if (const auto q = chiefImage(model, *aimer_, fieldDeg + spotRadius * d))
            r = std::min(r, glm::length(*q - *centre));
    if (!std::isfinite(r) || !(r > 0.0))
        throw ModelError(name, "the spot's rim does not image: no size for its image");
    gf.spotImageRadiusMm = r;
    gf.measuredSideMm = 0.5 * r;
    return gf;
}

SceneSpec GlareBench::scene(const GlareField& f, bool black, double sideMm, int pixels,
                            double fieldHalfAngleDeg) const {
    SceneSpec s = file_;
    AreaEmitter e;
    e.shape = AreaEmitter::Shape::Disk;
    e.radiusMm = windowRadiusMm_;
    // A narrower cone than the spec's still lights the whole port from every direction.
    e.coneHalfAngleRad =
        (fieldHalfAngleDeg > 0.0 ? std::min(fieldHalfAngleDeg, spec_.fieldHalfAngleDeg)
                                 : spec_.fieldHalfAngleDeg) *
        kDeg;
    e.frame.translation = Vec3(0.0, 0.0, windowZMm_);
    if (black) {
        e.blackSpotAxis = fieldDirection(f.fieldDeg.x, f.fieldDeg.y);
        e.blackSpotHalfAngleRad = 0.5 * spec_.spotDiameterDeg * kDeg;
    }
    // Radiance 1 (unit/(mm^2 sr)) outside the spot.
    s.sources = {Source(black ? "field with black spot" : "bright field", WindowSource{e},
                        e.areaMm2() * e.projectedSolidAngleSr(), *spectrum_)};
    DetectorSpec d;
    d.name = "glare";
    d.sizeMm = Vec2(sideMm);
    d.pixelsX = d.pixelsY = pixels;
    d.centerMm = f.imageMm;
    s.detectors = {d};
    return s;
}

SceneSpec GlareBench::spreadScene(const GlareField& f, double radiusMm, int pixels,
                                  double coreSideMm, int corePixels) const {
    SceneSpec s = file_;
    // The beam: a cylinder along the source's direction over the port (its hole through the
    // front plate, and 1 mm of the plate around it), starting in front of the plate.
    Beam b;
    b.direction = fieldDirection(f.fieldDeg.x, f.fieldDeg.y);
    const Vec3 ref = std::abs(b.direction.x) < 0.9 ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 1.0, 0.0);
    b.axisU = glm::normalize(ref - glm::dot(ref, b.direction) * b.direction);
    b.axisV = glm::cross(b.direction, b.axisU);
    const double cosT = b.direction.z, sinT = std::sqrt(std::max(0.0, 1.0 - cosT * cosT));
    b.apertureRadiusMm = portRadiusMm_;
    b.marginMm = 1.0;
    const double zMid = 0.5 * (portFrontZMm_ + portBackZMm_);
    b.radiusMm = portRadiusMm_ + b.marginMm + 0.5 * (portBackZMm_ - portFrontZMm_) * sinT;
    const double t0 = (zMid - windowZMm_ + b.radiusMm * sinT) / cosT;
    b.startCenterMm = Vec3(0.0, 0.0, zMid) - t0 * b.direction;
    s.sources = {Source("point source", CollimatedSource{b}, b.areaMm2(), *spectrum_)};
    DetectorSpec coarse;
    coarse.name = "gsf";
    coarse.sizeMm = Vec2(2.0 * radiusMm);
    coarse.pixelsX = coarse.pixelsY = pixels;
    coarse.centerMm = f.imageMm;
    DetectorSpec core = coarse;
    core.name = "gsf_core";
    core.sizeMm = Vec2(coreSideMm);
    core.pixelsX = core.pixelsY = corePixels;
    s.detectors = {coarse, core};
    return s;
}

double GlareBench::spreadRadiusMm(const GlareField& f) const {
    if (spec_.spreadRadiusMm > 0.0) return spec_.spreadRadiusMm;
    double r = 0.0;
    for (const Field& field : file_.prescription.system.fields)
        if (const auto q = chiefImage(*file_.model, *aimer_, Vec2(field.x, field.y)))
            r = std::max(r, glm::length(*q));
    return r > 20.0 * f.spotImageRadiusMm ? r : 20.0 * f.spotImageRadiusMm;
}

double GlareBench::fieldAngleAtHeight(double heightMm) const {
    // Up the y axis in half-degree steps until the chief ray lands past the height, then
    // bisection; 0 when it never does within the bright field.
    const double limit = spec_.fieldHalfAngleDeg - 0.5 * spec_.spotDiameterDeg;
    auto height = [&](double deg) -> std::optional<double> {
        const auto q = chiefImage(*file_.model, *aimer_, Vec2(0.0, deg));
        if (!q) return std::nullopt;
        return glm::length(*q);
    };
    double lo = 0.0, hi = 0.0;
    for (double deg = 0.5;; deg += 0.5) {
        if (deg > limit) return 0.0;
        const auto h = height(deg);
        if (!h) return 0.0;
        if (*h >= heightMm) {
            hi = deg;
            break;
        }
        lo = deg;
    }
    for (int i = 0; i < 50; ++i) {
        const double mid = 0.5 * (lo + hi);
        const auto h = height(mid);
        if (h && *h < heightMm)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

std::pair<double, double> GlareBench::ghostIrradiance(
    GlareField& f, const std::function<void(uint64_t, uint64_t)>& progress) const {
    const GhostTracer& tracer = *ghostTracer_;
    const double cosField = std::cos(spec_.fieldHalfAngleDeg * kDeg);
    AreaEmitter spot;
    spot.blackSpotAxis = fieldDirection(f.fieldDeg.x, f.fieldDeg.y);
    spot.blackSpotHalfAngleRad = 0.5 * spec_.spotDiameterDeg * kDeg;
    auto field = [&](bool black) {
        return [&, black](const Vec3& d) {
            if (d.z < cosField) return 0.0;
            return black && spot.inBlackSpot(d) ? 0.0 : 1.0;
        };
    };
    // The lens's lines as the field's spectrum shares them (its radiance splits so).
    auto irradiance = [&](const GhostPath& path, bool black) {
        double e = 0.0;
        // Line i of the field's spectrum is the model's wavelength i (fieldSpectrum).
        for (int i = 0; i < spectrum_->size(); ++i) {
            const double share = spectrum_->share(i);
            if (share > 0.0)
                e += share * tracer.backwardIrradiance(path, f.imageMm, i, field(black), 192);
        }
        return e;
    };
    // Paths in parallel (the tracer is read-only), summed in path order; in batches, so that
    // the progress is reported from this thread (a double Gauss's 2.7 s were silent).
    const std::vector<GhostPath> paths = tracer.enumerate();
    std::vector<double> each(paths.size(), 0.0);
    constexpr size_t kBatch = 32;
    for (size_t first = 0; first < paths.size(); first += kBatch) {
        const size_t last = std::min(paths.size(), first + kBatch);
        tbb::parallel_for(first, last, [&](size_t k) { each[k] = irradiance(paths[k], true); });
        if (progress) progress(last, paths.size());
    }
    double ghosts = 0.0;
    f.ghosts.clear();
    for (size_t k = 0; k < paths.size(); ++k) {
        ghosts += each[k];
        f.ghosts.push_back({paths[k].label, each[k]});
    }
    std::sort(f.ghosts.begin(), f.ghosts.end(),
              [](const GlareGhost& a, const GlareGhost& b) { return a.vgi > b.vgi; });
    return {ghosts, irradiance(tracer.nominalPath(), false)};
}

namespace {

// The lens stopped down to image-space F/# n: the stop's semi-diameter scaled by the paraxial
// F/# it has over n, the model rebuilt. ModelError for a scene without a stop plate or an
// F/# faster than the lens's.
SceneSpec stoppedDown(const SceneSpec& file, const GlassCatalog& catalog, double n, double own) {
    const std::string name = "--f-number " + significant(n, 4);
    if (!(n > 0.0) || !std::isfinite(n)) throw ModelError(name, "the F-number must be > 0");
    if (!file.mechanics || !file.mechanics->stop.enabled)
        throw ModelError(name, "the scene has no stop plate ([mechanics] stop) to stop down");
    if (n < own * (1.0 - 1e-9))
        throw ModelError(name, "faster than the lens's own f/" + significant(own, 4) +
                                   ": glare stops a lens down, it cannot open it up");
    SceneSpec s = file;
    Surface& stop = s.prescription.surfaces[static_cast<size_t>(s.prescription.stopIndex())];
    if (!(stop.clearSemiDiameterMm > 0.0))
        throw ModelError(name, "the stop has no semi-diameter to scale");
    stop.clearSemiDiameterMm *= own / n;
    s.model =
        std::make_shared<const SequentialModel>(SequentialModel::build(s.prescription, catalog));
    return s;
}

}  // namespace

namespace {

// Whether the GSF is measured at this position.
bool spreadAt(const GlareSpec& spec, const GlareField& f) {
    switch (spec.spread) {
        case GlareSpreadAt::None:
            return false;
        case GlareSpreadAt::Axis:
            return f.fieldDeg.x == 0.0 && f.fieldDeg.y == 0.0;
        case GlareSpreadAt::All:
            return true;
    }
    return false;
}

// The black and the white field (out to fieldHalfAngleDeg, 0: the spec's) rendered at f's
// measuring square, on p's geometry (its transport replaced): f's irradiances (black, its
// parts, white) are set.
void measure(PreparedScene& p, const GlareBench& bench, GlareField& f, const GlareSpec& spec,
             double fieldHalfAngleDeg, const GlassCatalog& catalog,
             const std::function<void(int)>& blackProgress,
             const std::function<void(int)>& whiteProgress) {
    for (const bool black : {true, false}) {
        SceneSpec file = bench.scene(f, black, f.measuredSideMm, spec.pixels, fieldHalfAngleDeg);
        file.detectors = p.spec().detectors;  // the geometry's (with the GSF's)
        p.replaceTransport(std::move(file), catalog);
        RenderRunSpec run;
        run.detector = "glare";
        run.options = spec.render;
        run.options.splitBackward = true;
        if (run.options.initialRadiusMm <= 0.0) run.options.initialRadiusMm = bench.radiusHintMm();
        run.stop.passes = spec.passes;
        // The black field's visible light through refractions (and mirrors) alone: the
        // image's blur; and with a total internal reflection: ghosts the ghost analysis does
        // not walk.
        if (black) run.where = {"not fresnel and not tir", "tir"};
        std::vector<double> total, specular, tir, blur, diffuse;
        const double area = f.measuredSideMm * f.measuredSideMm;
        (black ? blackProgress : whiteProgress)(0);
        RenderRun(p, run).run([&](const RenderPassEvent& e) {
            const int pass = e.pass;
            const RenderPassTotals t = passTotals(*e.rendered);
            constexpr auto kVisible = static_cast<size_t>(RenderComponent::Visible);
            const double visible = t.components[kVisible];
            double nominal = 0.0, internal = 0.0;
            if (black) {
                for (double v : e.rendered->criteria.at(0)[kVisible]) nominal += v;
                for (double v : e.rendered->criteria.at(1)[kVisible]) internal += v;
            }
            total.push_back(t.total() / area);
            specular.push_back((visible - nominal) / area);
            tir.push_back(internal / area);
            blur.push_back(nominal / area);
            diffuse.push_back((t.total() - visible) / area);
            (black ? blackProgress : whiteProgress)(pass);
        });
        if (black) {
            f.black = meanOf(total);
            f.blackSpecular = meanOf(specular);
            f.blackTir = meanOf(tir);
            f.blackBlur = meanOf(blur);
            f.blackDiffuse = meanOf(diffuse);
        } else {
            f.white = meanOf(total);
        }
    }
}

// Each pixel of a square detector (side sideMm, n pixels per side, centred on the point's
// image) split into 4 x 4 parts, each part's share given to the annulus of `edges` its centre
// lies in (none past the last edge): per pixel, its (annulus, share) pairs.
using PixelShares = std::vector<std::vector<std::pair<size_t, double>>>;
PixelShares annulusShares(double sideMm, int n, const std::vector<double>& edges) {
    constexpr int kSub = 4;
    constexpr double kShare = 1.0 / (kSub * kSub);
    PixelShares shares(static_cast<size_t>(n) * static_cast<size_t>(n));
    const double pitch = sideMm / n;
    for (int row = 0; row < n; ++row)
        for (int col = 0; col < n; ++col) {
            auto& out = shares[static_cast<size_t>(row) * static_cast<size_t>(n) +
                               static_cast<size_t>(col)];
            for (int j = 0; j < kSub; ++j)
                for (int i = 0; i < kSub; ++i) {
                    const double x = -0.5 * sideMm + (col + (i + 0.5) / kSub) * pitch;
                    const double y = 0.5 * sideMm - (row + (j + 0.5) / kSub) * pitch;
                    const auto it = std::upper_bound(edges.begin(), edges.end(), std::hypot(x, y));
                    if (it == edges.begin() || it == edges.end()) continue;
                    const size_t a = static_cast<size_t>(it - edges.begin()) - 1;
                    if (!out.empty() && out.back().first == a)
                        out.back().second += kShare;
                    else
                        out.push_back({a, kShare});
                }
        }
    return shares;
}

// A pass's flux per annulus (specular: the visible component; diffuse: the rest).
struct AnnulusFlux {
    std::vector<double> specular, diffuse;
};
AnnulusFlux binPass(const RenderPass& pass, const PixelShares& shares, size_t annuli) {
    AnnulusFlux a{std::vector<double>(annuli, 0.0), std::vector<double>(annuli, 0.0)};
    for (int c = 0; c < kRenderComponents; ++c) {
        std::vector<double>& to =
            c == static_cast<int>(RenderComponent::Visible) ? a.specular : a.diffuse;
        const std::vector<double>& pixels = pass.pixels[static_cast<size_t>(c)];
        for (size_t px = 0; px < pixels.size(); ++px)
            if (pixels[px] != 0.0)
                for (const auto& [k, share] : shares[px]) to[k] += share * pixels[px];
    }
    return a;
}

// The GSF's detectors about f's image: the core one covers 3.8 spot image radii.
constexpr int kCorePixels = 64;
double coreSideMm(const GlareField& f) { return 8.0 * f.spotImageRadiusMm; }

// The glare spread function at f (the header comment), on p's geometry, which has its
// detectors.
GlareSpread measureSpread(PreparedScene& p, const GlareBench& bench, const GlareField& f,
                          const GlareSpec& spec, const GlassCatalog& catalog,
                          const std::function<void(int)>& progress) {
    // The phase starts before its scene is built and its renderer set up (seconds on a
    // double Gauss).
    progress(0);
    GlareSpread g;
    const double rho = f.spotImageRadiusMm;
    g.radiusMm = bench.spreadRadiusMm(f);
    const int corePixels = kCorePixels;
    const double coreSide = coreSideMm(f);
    g.coreRadiusMm = 3.8 * rho;
    SceneSpec file = bench.spreadScene(f, g.radiusMm, spec.spreadPixels, coreSide, corePixels);
    file.detectors = p.spec().detectors;
    p.replaceTransport(std::move(file), catalog);

    // The annuli: a disc of the core detector's pitch, then ten per decade out to R.
    const double first = coreSide / corePixels;
    g.edgesMm = {0.0, first};
    const double step = std::pow(10.0, 0.1);
    while (g.edgesMm.back() * step < g.radiusMm * (1.0 - 1e-9))
        g.edgesMm.push_back(g.edgesMm.back() * step);
    g.edgesMm.push_back(g.radiusMm);
    const size_t annuli = g.edgesMm.size() - 1;
    // The VGI's three: the spot image, out to the core detector's reach, out to R.
    const std::vector<double> vgiEdges = {0.0, rho, g.coreRadiusMm, g.radiusMm};

    // [pass] flux per annulus, from the core detector and from the coarse one.
    std::vector<AnnulusFlux> coreCurve, coarseCurve, coreVgi, coarseVgi;
    RenderRunSpec run;
    run.options = spec.render;
    run.options.splitBackward = true;
    // Annuli average many pixels: fewer rays per pixel, and each deposit in its own pixel.
    run.options.raysPerPixel = std::max<uint64_t>(1, spec.render.raysPerPixel / 16);
    run.options.detectorRadiusPixels = 0.0;
    if (run.options.initialRadiusMm <= 0.0) run.options.initialRadiusMm = bench.radiusHintMm();
    run.stop.passes = spec.passes;
    for (const bool core : {true, false}) {
        const double side = core ? coreSide : 2.0 * g.radiusMm;
        const int n = core ? corePixels : spec.spreadPixels;
        const PixelShares curve = annulusShares(side, n, g.edgesMm);
        const PixelShares vgi = annulusShares(side, n, vgiEdges);
        run.detector = core ? "gsf_core" : "gsf";
        RenderRun(p, run).run([&](const RenderPassEvent& e) {
            const int pass = e.pass;
            const RenderPassTotals t = passTotals(*e.rendered);
            (core ? coreCurve : coarseCurve).push_back(binPass(*e.rendered, curve, annuli));
            (core ? coreVgi : coarseVgi).push_back(binPass(*e.rendered, vgi, 3));
            progress(core ? pass : spec.passes + pass);
        });
    }

    // Per pass: the disc's flux, the VGI and its parts, the annuli's irradiance.
    const size_t passes = coreVgi.size();
    std::vector<double> disc(passes), vgi(passes), specular(passes), diffuse(passes);
    for (size_t k = 0; k < passes; ++k) {
        // Inside the core's reach from the core detector, past it from the coarse one.
        double outsideSpecular = 0.0, outsideDiffuse = 0.0, inside = 0.0;
        for (size_t b = 0; b < 3; ++b) {
            const AnnulusFlux& from = b < 2 ? coreVgi[k] : coarseVgi[k];
            if (b == 0) {
                inside = from.specular[b] + from.diffuse[b];
            } else {
                outsideSpecular += from.specular[b];
                outsideDiffuse += from.diffuse[b];
            }
        }
        disc[k] = inside + outsideSpecular + outsideDiffuse;
        if (disc[k] > 0.0) {
            vgi[k] = (outsideSpecular + outsideDiffuse) / disc[k];
            specular[k] = outsideSpecular / disc[k];
            diffuse[k] = outsideDiffuse / disc[k];
        }
    }
    g.discFlux = meanOf(disc);
    g.vgi = meanOf(vgi);
    g.vgiSpecular = meanOf(specular);
    g.vgiDiffuse = meanOf(diffuse);
    const double norm = g.discFlux.value;
    for (size_t a = 0; a < annuli; ++a) {
        const bool core = g.edgesMm[a + 1] <= g.coreRadiusMm * (1.0 + 1e-12);
        const double area =
            std::numbers::pi * (g.edgesMm[a + 1] * g.edgesMm[a + 1] - g.edgesMm[a] * g.edgesMm[a]);
        std::vector<double> t(passes), s(passes), d(passes);
        for (size_t k = 0; k < passes; ++k) {
            const AnnulusFlux& from = core ? coreCurve[k] : coarseCurve[k];
            const double scale = norm > 0.0 ? 1.0 / (area * norm) : 0.0;
            s[k] = from.specular[a] * scale;
            d[k] = from.diffuse[a] * scale;
            t[k] = s[k] + d[k];
        }
        g.total.push_back(meanOf(t));
        g.specular.push_back(meanOf(s));
        g.diffuse.push_back(meanOf(d));
    }
    return g;
}

}  // namespace

GlareResult runGlare(const SceneSpec& file, const GlassCatalog& catalog, const GlareSpec& spec) {
    const auto start = std::chrono::steady_clock::now();
    const double own =
        computeFirstOrder(*file.model, file.model->primaryWavelength()).imageSpaceFNumber;
    // Every aperture and position is checked before the first render.
    std::vector<std::pair<double, SceneSpec>> apertures;
    if (spec.fNumbers.empty()) apertures.push_back({own, file});
    for (double n : spec.fNumbers) apertures.push_back({n, stoppedDown(file, catalog, n, own)});
    std::vector<Vec2> fields = spec.fieldsDeg;
    for (size_t f = 0; f < fields.size(); ++f)
        checkFieldAngles(fields[f].x, fields[f].y, "--field " + std::to_string(f + 1));
    if (fields.empty()) {
        fields.push_back(Vec2(0.0));
        for (const Field& f : file.prescription.system.fields)
            if (f.x != 0.0 || f.y != 0.0) fields.push_back(Vec2(f.x, f.y));
    }
    std::vector<std::unique_ptr<GlareBench>> benches;
    std::vector<GlareField> located;
    for (size_t a = 0; a < apertures.size(); ++a) {
        benches.push_back(std::make_unique<GlareBench>(apertures[a].second, catalog, spec));
        for (const Vec2& f : fields) {
            located.push_back(benches.back()->locate(f));
            located.back().fNumber = apertures[a].first;
            const GlareField& gf = located.back();
            const double radius = benches.back()->spreadRadiusMm(gf);
            if (spreadAt(spec, gf) && !(radius > 3.8 * gf.spotImageRadiusMm))
                throw ModelError("--gsf-radius-mm",
                                 "the GSF's disc (" + significant(radius, 4) +
                                     " mm) must reach past 3.8 spot image radii (" +
                                     significant(3.8 * gf.spotImageRadiusMm, 4) + " mm)");
        }
    }

    GlareResult result;
    result.spotDiameterDeg = spec.spotDiameterDeg;
    result.fieldHalfAngleDeg = spec.fieldHalfAngleDeg;
    result.passes = spec.passes;
    result.raysPerPixel = spec.render.raysPerPixel;
    result.photonsPerPass = spec.render.photonsPerPass;
    result.spectrum = benches.front()->spectrumText();
    result.unit = benches.front()->unit();

    for (size_t fi = 0; fi < located.size(); ++fi) {
        const GlareBench& bench = *benches[fi / fields.size()];
        GlareField gf = located[fi];
        // One geometry per position, with the measuring square and the GSF's detectors on the
        // image surface: the white field, the point source and the check's fields replace the
        // black field's transport.
        SceneSpec first = bench.scene(gf, true, gf.measuredSideMm, spec.pixels);
        if (spreadAt(spec, gf)) {
            const double radius = bench.spreadRadiusMm(gf);
            const SceneSpec s =
                bench.spreadScene(gf, radius, spec.spreadPixels, coreSideMm(gf), kCorePixels);
            first.detectors.insert(first.detectors.end(), s.detectors.begin(), s.detectors.end());
        }
        const std::unique_ptr<PreparedScene> p = PreparedScene::build(std::move(first), catalog);
        auto progress = [&](const std::string& run, int passes) {
            return [&, run, passes](int pass) {
                if (spec.progress)
                    spec.progress({"glare: position " + std::to_string(fi + 1) + ", " + run,
                                   static_cast<uint64_t>(pass), static_cast<uint64_t>(passes),
                                   "passes"});
            };
        };
        measure(*p, bench, gf, spec, 0.0, catalog, progress("black field", spec.passes),
                progress("white field", spec.passes));
        const auto [ghosts, image] = bench.ghostIrradiance(gf, [&](uint64_t done, uint64_t total) {
            if (spec.progress)
                spec.progress({"glare: position " + std::to_string(fi + 1) + ", ghost prediction",
                               done, total, "ghost paths"});
        });
        if (gf.white.value > 0.0) {
            gf.ghostPrediction = ghosts / gf.white.value;
            gf.imagePrediction = image / gf.white.value;
            for (GlareGhost& g : gf.ghosts) g.vgi /= gf.white.value;
        }
        gf.vgi = ratio(gf.black, gf.white);
        gf.specular = ratio(gf.blackSpecular, gf.white);
        gf.tir = ratio(gf.blackTir, gf.white);
        gf.blur = ratio(gf.blackBlur, gf.white);
        gf.diffuse = ratio(gf.blackDiffuse, gf.white);
        if (spreadAt(spec, gf)) {
            gf.spread = measureSpread(*p, bench, gf, spec, catalog,
                                      progress("point source", 2 * spec.passes));
            GlareSpread& g = *gf.spread;
            const bool onAxis = gf.fieldDeg.x == 0.0 && gf.fieldDeg.y == 0.0;
            const double theta = onAxis ? bench.fieldAngleAtHeight(g.radiusMm) : 0.0;
            if (theta > 0.0) {
                g.fieldDeg = theta;
                GlareField c = gf;  // the same square, the field out to theta
                measure(*p, bench, c, spec, theta, catalog,
                        progress("check, black field", spec.passes),
                        progress("check, white field", spec.passes));
                g.directVgi = ratio(c.black, c.white);
                g.directSpecular = ratio(c.blackSpecular, c.white);
                g.directDiffuse = ratio(c.blackDiffuse, c.white);
            }
        }
        result.fields.push_back(gf);
    }
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

namespace {

// In percent: three significant digits for values of 1 % and less (down to 0.0001 %), two
// decimals above; the error to the value's last digit or its own first two.
std::string percent(const GlareValue& v) {
    const double p = 100.0 * v.value, e = 100.0 * v.error;
    int decimals = 2;
    if (p > 0.0 && p < 1.0) decimals = std::min(6, 2 - static_cast<int>(std::floor(std::log10(p))));
    int errorDecimals = decimals;
    if (e > 0.0)
        errorDecimals =
            std::max(decimals, std::min(6, 1 - static_cast<int>(std::floor(std::log10(e)))));
    std::ostringstream os;
    os << std::fixed << std::setprecision(decimals) << p << " +- "
       << std::setprecision(errorDecimals) << e << " %";
    return os.str();
}

nlohmann::json valueJson(const GlareValue& v) { return {{"value", v.value}, {"error", v.error}}; }

// CSV numbers: nine significant digits.
std::string csv9(double v) {
    std::ostringstream os;
    os << std::setprecision(9) << v;
    return os.str();
}

ReportCell csvNumber(double v) { return ReportCell::number(v, csv9(v), "", ""); }

// A measured value: its CSV number, its percent with error in Markdown, {value, error} in JSON.
ReportCell measured(const GlareValue& v) {
    ReportCell c = ReportCell::number(v.value, csv9(v.value), percent(v), percent(v));
    c.json = valueJson(v);
    return c;
}

ReportColumn only(const std::string& key, const std::string& heading, bool csv, bool markdown,
                  bool json, const std::string& rule = "---:") {
    ReportColumn c{key, heading};
    c.csv = csv;
    c.markdown = markdown;
    c.json = json;
    c.terminal = markdown;
    c.markdownRule = rule;
    return c;
}


nlohmann::json spreadJson(const GlareSpread& g) {
    nlohmann::json gsf = {{"radius_mm", g.radiusMm},
                          {"core_radius_mm", g.coreRadiusMm},
                          {"edges_mm", g.edgesMm},
                          {"disc_flux", valueJson(g.discFlux)},
                          {"vgi", valueJson(g.vgi)},
                          {"vgi_specular", valueJson(g.vgiSpecular)},
                          {"vgi_diffuse", valueJson(g.vgiDiffuse)}};
    for (const auto& [name, values] :
         {std::pair{"gsf", &g.total}, std::pair{"gsf_specular", &g.specular},
          std::pair{"gsf_diffuse", &g.diffuse}}) {
        nlohmann::json v = nlohmann::json::array(), e = nlohmann::json::array();
        for (const GlareValue& x : *values) {
            v.push_back(x.value);
            e.push_back(x.error);
        }
        gsf[name] = v;
        gsf[std::string(name) + "_error"] = e;
    }
    if (g.fieldDeg > 0.0) {
        gsf["field_deg"] = g.fieldDeg;
        gsf["direct_vgi"] = valueJson(g.directVgi);
        gsf["direct_specular"] = valueJson(g.directSpecular);
        gsf["direct_diffuse"] = valueJson(g.directDiffuse);
    }
    return gsf;
}

}  // namespace

std::string GlareResult::markdown() const {
    std::ostringstream os;
    os << "Veiling glare index (ISO 9358's definition: irradiance at the centre of a black "
          "spot's image over the irradiance there without the spot), black spot "
       << significant(spotDiameterDeg, 4) << " deg across in a uniform Lambertian field out to "
       << significant(fieldHalfAngleDeg, 4) << " deg from the axis; " << spectrum << ". " << passes
       << " render passes of " << raysPerPixel << " rays per pixel and " << photonsPerPass
       << " photons; errors 1 sigma.\n\n";
    os << table().markdown();
    for (const GlareField& f : fields)
        if (f.blur.value > 0.05 * f.vgi.value && f.vgi.value > 0.0)
            os << "\nAt " << significant(f.fieldDeg.x, 4) << ", " << significant(f.fieldDeg.y, 4)
               << " deg (f/" << significant(f.fNumber, 3) << ") the lens's own image blur brings "
               << percent(f.blur)
               << " into the spot's centre: the black spot is small for this lens's "
                  "aberrations (ISO 9358's VGI is glare, not blur); a larger --spot-deg leaves "
                  "it out.\n";
    os << "\nVia TIR: ghosts one of whose two reflections is total internal reflection (light "
          "of the wide field meeting a steep face from inside the glass). Image blur: light "
          "through refractions alone (the lens's image of the field around the spot, spread into "
          "its centre by aberrations). Ghost analysis: the specular part as the sequential ghost "
          "analysis predicts it (every two-Fresnel-reflection ghost walked backward from the "
          "spot's image centre; it leaves out the mechanics, TIR and higher-order ghosts, which "
          "the render includes).";
    if (!fields.empty() && !fields.front().ghosts.empty()) {
        const GlareField& f = fields.front();
        os << " Its brightest ghosts at " << significant(f.fieldDeg.x, 4) << ", "
           << significant(f.fieldDeg.y, 4) << " deg:\n\n";
        ReportTable ghosts(std::vector<ReportColumn>{only("ghost", "ghost", false, true, false, "---"),
                                                     only("vgi", "VGI", false, true, false)});
        for (size_t i = 0; i < f.ghosts.size() && i < 5; ++i)
            ghosts.addRow({ReportCell::text(f.ghosts[i].label),
                           ReportCell::text(significant(100.0 * f.ghosts[i].vgi, 4) + " %")});
        os << ghosts.markdown();
    } else {
        os << "\n";
    }
    bool spreads = false;
    for (const GlareField& f : fields) spreads = spreads || f.spread.has_value();
    if (spreads) {
        os << "\nGlare spread function: a point source at each position, the irradiance at "
              "distance r from its image over the flux it brings to a disc of radius R about "
              "the image (gsf.csv, gsf.png). The VGI recomputed from it is the disc's flux "
              "outside the spot's image over all of it: the VGI of a bright field whose image "
              "is the disc, if the GSF were the same at every point of the image "
              "(isoplanatic). On axis the disc is the image of a cone of the field (theta_R), "
              "and that field's VGI is rendered directly as the check; ghosts, which move "
              "across the image at their own rate, make the two differ (docs/glare.md).\n\n";
        os << spreadSummaryTable().markdown();
    }
    return os.str();
}

ReportTable GlareResult::table() const {
    std::vector<ReportColumn> columns{
        only("f_number", "f/#", true, true, true),
        only("field_x_deg", "", true, false, false),
        only("field_y_deg", "", true, false, false),
        only("field_deg", "field (deg)", false, true, true, "---"),
        only("image_x_mm", "", true, false, false),
        only("image_y_mm", "", true, false, false),
        only("image_mm", "image (mm)", false, true, true, "---"),
        only("spot_image_radius_mm", "", true, false, true),
        only("measured_side_mm", "", false, false, true),
        only("vgi", "VGI", true, true, true),
        only("vgi_error", "", true, false, false),
        only("specular", "specular (ghosts)", true, true, true),
        only("specular_error", "", true, false, false),
        only("tir", "of which via TIR", true, true, true),
        only("tir_error", "", true, false, false),
        only("diffuse", "diffuse (scatter)", true, true, true),
        only("diffuse_error", "", true, false, false),
        only("blur", "image blur", true, true, true),
        only("blur_error", "", true, false, false),
        only("ghost_prediction", "ghost analysis", true, true, true),
        only("image_prediction", "", false, false, true),
        only("black", "", true, false, true).withCsvHeader("black_" + unit + "_mm2"),
        only("black_error", "", true, false, false),
        only("white", "", true, false, true).withCsvHeader("white_" + unit + "_mm2"),
        only("white_error", "", true, false, false),
        only("gsf", "", false, false, true)};
    ReportTable table(std::move(columns));
    for (const GlareField& f : fields) {
        ReportCell fNumber = csvNumber(f.fNumber);
        fNumber.markdown = significant(f.fNumber, 3);
        ReportCell field =
            ReportCell::text(significant(f.fieldDeg.x, 4) + ", " + significant(f.fieldDeg.y, 4));
        field.json = {f.fieldDeg.x, f.fieldDeg.y};
        ReportCell image =
            ReportCell::text(significant(f.imageMm.x, 5) + ", " + significant(f.imageMm.y, 5));
        image.json = {f.imageMm.x, f.imageMm.y};
        ReportCell side = csvNumber(f.measuredSideMm);
        ReportCell ghosts = csvNumber(f.ghostPrediction);
        ghosts.markdown = significant(100.0 * f.ghostPrediction, 4) + " %";
        ReportCell gsf = ReportCell::text("");
        if (f.spread)
            gsf.json = spreadJson(*f.spread);
        else
            gsf.withoutJson();
        table.addRow({fNumber, csvNumber(f.fieldDeg.x), csvNumber(f.fieldDeg.y), field,
                      csvNumber(f.imageMm.x), csvNumber(f.imageMm.y), image,
                      csvNumber(f.spotImageRadiusMm), side, measured(f.vgi),
                      csvNumber(f.vgi.error), measured(f.specular), csvNumber(f.specular.error),
                      measured(f.tir), csvNumber(f.tir.error), measured(f.diffuse),
                      csvNumber(f.diffuse.error), measured(f.blur), csvNumber(f.blur.error),
                      ghosts, csvNumber(f.imagePrediction), measured(f.black),
                      csvNumber(f.black.error), measured(f.white), csvNumber(f.white.error), gsf});
    }
    return table;
}

ReportTable GlareResult::spreadSummaryTable() const {
    ReportTable table(std::vector<ReportColumn>{
        only("f_number", "f/#", false, true, false),
        only("field_deg", "field (deg)", false, true, false, "---"),
        only("radius_mm", "R (mm)", false, true, false),
        only("vgi", "VGI from GSF", false, true, false),
        only("vgi_specular", "specular", false, true, false),
        only("vgi_diffuse", "diffuse", false, true, false),
        only("theta_r", "theta_R", false, true, false),
        only("direct_vgi", "direct VGI, field to theta_R", false, true, false),
        only("direct_specular", "specular", false, true, false),
        only("direct_diffuse", "diffuse", false, true, false)});
    for (const GlareField& f : fields) {
        if (!f.spread) continue;
        const GlareSpread& g = *f.spread;
        const bool direct = g.fieldDeg > 0.0;
        auto text = [](const std::string& s) { return ReportCell::text(s); };
        table.addRow({text(significant(f.fNumber, 3)),
                      text(significant(f.fieldDeg.x, 4) + ", " + significant(f.fieldDeg.y, 4)),
                      text(significant(g.radiusMm, 4)), text(percent(g.vgi)),
                      text(percent(g.vgiSpecular)), text(percent(g.vgiDiffuse)),
                      text(direct ? significant(g.fieldDeg, 4) + " deg" : "-"),
                      text(direct ? percent(g.directVgi) : "-"),
                      text(direct ? percent(g.directSpecular) : "-"),
                      text(direct ? percent(g.directDiffuse) : "-")});
    }
    return table;
}

ReportTable GlareResult::spreadTable() const {
    ReportTable table;
    for (const char* k : {"f_number", "field_x_deg", "field_y_deg", "r_inner_mm", "r_outer_mm",
                          "r_mm", "gsf_per_mm2", "gsf_error", "specular_per_mm2",
                          "specular_error", "diffuse_per_mm2", "diffuse_error"})
        table.addColumn(only(k, k, true, false, true));
    for (const GlareField& f : fields) {
        if (!f.spread) continue;
        const GlareSpread& g = *f.spread;
        for (size_t a = 0; a < g.total.size(); ++a) {
            const double lo = g.edgesMm[a], hi = g.edgesMm[a + 1];
            table.addRow({csvNumber(f.fNumber), csvNumber(f.fieldDeg.x), csvNumber(f.fieldDeg.y),
                          csvNumber(lo), csvNumber(hi), csvNumber(spreadRadius(lo, hi)),
                          csvNumber(g.total[a].value), csvNumber(g.total[a].error),
                          csvNumber(g.specular[a].value), csvNumber(g.specular[a].error),
                          csvNumber(g.diffuse[a].value), csvNumber(g.diffuse[a].error)});
        }
    }
    return table;
}

std::string GlareResult::csv() const { return table().csv(); }

std::string GlareResult::spreadCsv() const { return spreadTable().csv(); }

std::string GlareResult::json() const {
    nlohmann::json j;
    j["spot_diameter_deg"] = spotDiameterDeg;
    j["field_half_angle_deg"] = fieldHalfAngleDeg;
    j["spectrum"] = spectrum;
    j["unit"] = unit;
    j["passes"] = passes;
    j["rays_per_pixel"] = raysPerPixel;
    j["photons_per_pass"] = photonsPerPass;
    j["seconds"] = seconds;
    j["fields"] = table().json();
    return j.dump(2) + "\n";
}

// The glare spread functions, log-log: every position's total; with one position, its
// specular and diffuse parts too. The spot image's radius of the first position marked.
ChartSpec GlareResult::spreadChart() const {
    ChartSpec chart;
    chart.title = "Glare spread function: a point source's stray light around its image";
    chart.xLabel = "distance from the point source's image (mm)";
    chart.yLabel = "GSF (1/mm^2: irradiance over the disc's flux)";
    chart.logX = chart.logY = true;
    auto label = [](const GlareField& f) {
        std::ostringstream os;
        os << std::setprecision(4) << f.fieldDeg.x << ", " << f.fieldDeg.y << " deg, f/"
           << std::setprecision(3) << f.fNumber;
        return os.str();
    };
    size_t spreads = 0;
    for (const GlareField& f : fields) spreads += f.spread ? 1 : 0;
    for (const GlareField& f : fields) {
        if (!f.spread) continue;
        const GlareSpread& g = *f.spread;
        auto series = [&](const std::string& name, const std::vector<GlareValue>& v, bool dashed) {
            ChartSeries s{name, {}, {}, {}, dashed, false};
            for (size_t a = 0; a < v.size(); ++a) {
                s.x.push_back(spreadRadius(g.edgesMm[a], g.edgesMm[a + 1]));
                s.y.push_back(v[a].value);
                s.yError.push_back(v[a].error);
            }
            return s;
        };
        chart.series.push_back(series(spreads > 1 ? label(f) : "total", g.total, false));
        if (spreads == 1) {
            chart.series.push_back(series("specular (image and ghosts)", g.specular, true));
            chart.series.push_back(series("diffuse (scatter)", g.diffuse, true));
        }
    }
    for (const GlareField& f : fields)
        if (f.spread) {
            chart.xMarkers.push_back({f.spotImageRadiusMm, "spot image"});
            break;
        }
    return chart;
}

ChartSpec GlareResult::vgiChart() const {
    ChartSpec chart;
    chart.title = "Veiling glare index, black spot " +
                  std::to_string(spotDiameterDeg).substr(0, 4) + " deg";
    chart.xLabel = "field angle of the black spot (deg)";
    chart.yLabel = "VGI (%)";
    std::vector<double> apertures;
    for (const GlareField& f : fields)
        if (std::find(apertures.begin(), apertures.end(), f.fNumber) == apertures.end())
            apertures.push_back(f.fNumber);
    auto fnum = [](double n) {
        std::ostringstream os;
        os << "f/" << std::setprecision(3) << n;
        return os.str();
    };
    for (double n : apertures) {
        const std::string tag = apertures.size() > 1 ? " " + fnum(n) : "";
        ChartSeries total{"VGI" + tag, {}, {}, {}},
            specular{"specular (ghosts)" + tag, {}, {}, {}, true},
            diffuse{"diffuse (scatter)" + tag, {}, {}, {}, true};
        for (const GlareField& f : fields) {
            if (f.fNumber != n) continue;
            const double angle = std::hypot(f.fieldDeg.x, f.fieldDeg.y);
            for (auto [s, v] : {std::pair{&total, f.vgi}, std::pair{&specular, f.specular},
                                std::pair{&diffuse, f.diffuse}}) {
                s->x.push_back(angle);
                s->y.push_back(100.0 * v.value);
                s->yError.push_back(100.0 * v.error);
            }
        }
        chart.series.push_back(total);
        if (apertures.size() == 1) {
            chart.series.push_back(specular);
            chart.series.push_back(diffuse);
        }
    }
    return chart;
}

std::vector<std::filesystem::path> writeGlareFiles(const GlareResult& result,
                                                   const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> written;
    std::filesystem::create_directories(dir);
    std::vector<std::pair<std::string, std::string>> files = {{"glare.md", result.markdown()},
                                                              {"glare.csv", result.csv()},
                                                              {"glare.json", result.json()}};
    bool spreads = false;
    for (const GlareField& f : result.fields) spreads = spreads || f.spread.has_value();
    if (spreads) files.push_back({"gsf.csv", result.spreadCsv()});
    for (const auto& [name, text] : files) {
        writeTextFile(dir / name, text);
        written.push_back(dir / name);
    }
    auto picture = [&](const ChartSpec& chart, const std::string& stem) {
        const Picture pic = drawChart(chart);
        pic.writeSvg(dir / (stem + ".svg"));
        written.push_back(dir / (stem + ".svg"));
        pic.writePng(dir / (stem + ".png"), 1600);
        written.push_back(dir / (stem + ".png"));
    };
    if (spreads) picture(result.spreadChart(), "gsf");
    if (result.fields.size() >= 2) picture(result.vgiChart(), "glare");
    return written;
}

}  // namespace veil
