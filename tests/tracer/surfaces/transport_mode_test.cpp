// Transport modes of OpticalProperty (optical_property.h): the adjoint BSDF that backward
// (importance) paths evaluate, the n^2 rule of their specular transmission weight, reciprocity
// of the scatter models, and the energy each mode's BSDF carries.
//
// Independent truths: contexts of the reversed light built here by hand, the projected solid
// angle ratio of refraction from finite differences of refract(), the Gaussian lobe's mass
// above the horizon by brute-force quadrature, and Monte Carlo integrals over uniformly
// sampled hemispheres (z-scores, fixed seeds) against the channel fractions.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <sstream>

#include "geometry/numerics.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {
namespace {

double deg(double d) { return d * kPi / 180.0; }

// A tilted normal so that no test leans on z being special.
const Vec3 kNormal = glm::normalize(Vec3(-0.2, 0.4, 0.9));

struct Basis {
    Vec3 t1, t2, n;
};
Basis basisOf(const Vec3& n) {
    const Vec3 helper = std::abs(n.x) < 0.6 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    const Vec3 t1 = glm::normalize(glm::cross(n, helper));
    return {t1, glm::cross(n, t1), n};
}
// The unit direction at polar angle theta (rad) about axis n, azimuth phi.
Vec3 polar(const Basis& b, double theta, double phi) {
    return std::sin(theta) * (std::cos(phi) * b.t1 + std::sin(phi) * b.t2) + std::cos(theta) * b.n;
}

// A path arriving at the surface (travelling along `direction`) from the normal's side.
SurfaceContext contextFrom(const Vec3& direction, double n1, double n2) {
    SurfaceContext c;
    c.normal = kNormal;
    c.direction = direction;
    c.n1 = n1;
    c.n2 = n2;
    return c;
}
SurfaceContext contextAt(double incidenceDeg, double azimuthDeg, double n1, double n2) {
    return contextFrom(-polar(basisOf(kNormal), deg(incidenceDeg), deg(azimuthDeg)), n1, n2);
}

// The light that a backward path meets, built without reverseContext(): it arrives along
// -out from the side `out` points into and leaves along -c.direction.
SurfaceContext lightContext(const SurfaceContext& c, const Vec3& out) {
    SurfaceContext l;
    l.direction = -out;
    l.wavelengthNm = c.wavelengthNm;
    const bool across = glm::dot(out, kNormal) < 0.0;
    l.normal = across ? -kNormal : kNormal;
    l.n1 = across ? c.n2 : c.n1;
    l.n2 = across ? c.n1 : c.n2;
    return l;
}

struct Estimate {
    double mean = 0.0, sigma = 0.0;
    double z(double truth) const { return (mean - truth) / sigma; }
};
std::ostream& operator<<(std::ostream& os, const Estimate& e) {
    return os << e.mean << " +- " << e.sigma;
}
// Integral over the hemisphere about `axis` of f(w) dw, w uniform in solid angle.
template <class F>
Estimate hemisphereIntegral(const Vec3& axis, int n, uint64_t seed, F&& f) {
    const Basis b = basisOf(axis);
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
        CounterRng rng(seed, static_cast<uint64_t>(i));
        const double cosT = rng.uniform(), phi = 2.0 * kPi * rng.uniform();
        const Vec3 w = polar(b, std::acos(cosT), phi);
        const double x = 2.0 * kPi * f(w);
        s1 += x;
        s2 += x * x;
    }
    const double mean = s1 / n;
    return {mean, std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1))};
}

// Reflection: Reciprocity

TEST(TransportMode, LambertianAndAbgReflectionAreReciprocal) {
    // Lambertian: a constant; ABg: A / (B + |beta - beta0|^g) is symmetric in the two
    // projections. Tolerance 1e-12 relative (pow and the projections round differently when
    // the roles swap; the TIS table is not involved in the bsdf).
    const OpticalProperty lambert("paint", AbsorberSpecular{}, LambertianScatter{0.3, 0.0});
    const OpticalProperty abg("abg", FresnelSpecular{},
                              AbgScatter(AbgParams{0.01, 1e-3, 1.8}, std::nullopt));
    const Basis b = basisOf(kNormal);
    CounterRng rng(17, 3);
    for (int i = 0; i < 200; ++i) {
        const Vec3 in = -polar(b, 0.49 * kPi * rng.uniform(), 2 * kPi * rng.uniform());
        const Vec3 out = polar(b, 0.49 * kPi * rng.uniform(), 2 * kPi * rng.uniform());
        const SurfaceContext c = contextFrom(in, 1.0, 1.5), r = contextFrom(-out, 1.0, 1.5);
        for (const OpticalProperty* p : {&lambert, &abg}) {
            const double f = p->bsdf(c, out);
            ASSERT_GT(f, 0.0);
            EXPECT_NEAR(p->bsdf(r, -in), f, 1e-12 * f) << *p;
            // So the adjoint is the BSDF itself.
            EXPECT_NEAR(p->bsdf(c, out, TransportMode::Importance), f, 1e-12 * f) << *p;
            EXPECT_EQ(p->bsdf(c, out, TransportMode::Flux), f);
        }
    }
}

// The unclipped Gaussian lobe's mass above the horizon for an axis at angle a from the normal,
// by brute force (midpoint rule in polar coordinates about the normal).
double gaussianMassAbove(double kappa, double axisAngleRad) {
    const int nt = 600, np = 600;
    const Basis b = basisOf(Vec3(0, 0, 1));
    const Vec3 axis = polar(b, axisAngleRad, 0.0);
    double above = 0.0;
    for (int i = 0; i < nt; ++i) {
        const double t = (i + 0.5) * 0.5 * kPi / nt;
        for (int j = 0; j < np; ++j) {
            const double phi = (j + 0.5) * 2 * kPi / np;
            const Vec3 w = polar(b, t, phi);
            above += std::exp(-kappa * (1.0 - glm::dot(w, axis))) * std::sin(t);
        }
    }
    above *= (0.5 * kPi / nt) * (2 * kPi / np);
    return above * kappa / (2 * kPi * -std::expm1(-2.0 * kappa));
}

TEST(TransportMode, GaussianLobeIsNotReciprocalAndTheAdjointReversesIt) {
    const double hwhmDeg = 25.0;
    const GaussianScatter g(0.2, 0.0, hwhmDeg);
    const OpticalProperty p("g", AbsorberSpecular{}, g);
    const Basis b = basisOf(kNormal);
    // Equal polar angles: reciprocal (the lobe's angle and mass are the same both ways).
    for (double phi : {0.3, 1.7, 3.0}) {
        const Vec3 in = -polar(b, deg(40.0), 0.0), out = polar(b, deg(40.0), phi);
        const double f = p.bsdf(contextFrom(in, 1, 1), out);
        EXPECT_NEAR(p.bsdf(contextFrom(-out, 1, 1), -in), f, 1e-12 * f);
    }
    // Otherwise f(in -> out) / f(-out -> -in) = cos(i) M(o) / (cos(o) M(i)): the lobe is an
    // intensity distribution renormalised per incidence, not a reciprocal BRDF.
    const double ti = deg(75.0), to = deg(20.0);
    const Vec3 in = -polar(b, ti, 0.0), out = polar(b, to, 2.5);
    const SurfaceContext c = contextFrom(in, 1, 1);
    const double forward = p.bsdf(c, out), backward = p.bsdf(contextFrom(-out, 1, 1), -in);
    const double mi = gaussianMassAbove(g.kappa(), ti), mo = gaussianMassAbove(g.kappa(), to);
    EXPECT_NEAR(forward / backward, std::cos(ti) * mo / (std::cos(to) * mi), 1e-6);
    EXPECT_GT(std::abs(forward / backward - 1.0), 0.5);  // far from reciprocal here
    // The adjoint is the reversed light's bsdf, not the forward one.
    EXPECT_NEAR(p.bsdf(c, out, TransportMode::Importance), backward, 1e-15 * backward);
    EXPECT_EQ(p.bsdf(c, out, TransportMode::Flux), forward);
}

// Transmission: The Adjoint

TEST(TransportMode, AdjointOfTransmissionIsTheReversedLightsBsdf) {
    const OpticalProperty lambert("diffuser", FresnelSpecular{}, LambertianScatter{0.1, 0.4});
    const OpticalProperty gauss("frosted", FresnelSpecular{}, GaussianScatter(0.05, 0.3, 15.0));
    const OpticalProperty abg("abg", FresnelSpecular{},
                              AbgScatter(std::nullopt, AbgParams{0.02, 0.01, 2.0}));
    const Basis b = basisOf(kNormal);
    CounterRng rng(23, 1);
    for (const auto& [n1, n2] : {std::pair(1.0, 1.5), std::pair(1.5, 1.0)}) {
        int evaluated = 0;
        for (int i = 0; i < 300; ++i) {
            const Vec3 in = -polar(b, 0.45 * kPi * rng.uniform(), 2 * kPi * rng.uniform());
            const Vec3 out = -polar(b, 0.45 * kPi * rng.uniform(), 2 * kPi * rng.uniform());
            const SurfaceContext c = contextFrom(in, n1, n2);
            const SurfaceContext light = lightContext(c, out);
            EXPECT_EQ(light.n1, n2);
            for (const OpticalProperty* p : {&lambert, &gauss, &abg}) {
                const double adjoint = p->bsdf(c, out, TransportMode::Importance);
                // The importance-mode BSDF of this step is the flux-mode BSDF of the
                // forward (light) step.
                EXPECT_EQ(adjoint, p->bsdf(light, -in, TransportMode::Flux)) << *p;
                // And the other way round: adjoint of the adjoint.
                EXPECT_EQ(p->bsdf(light, -in, TransportMode::Importance),
                          p->bsdf(c, out, TransportMode::Flux))
                    << *p;
                if (adjoint > 0.0) ++evaluated;
            }
        }
        EXPECT_GT(evaluated, 300);  // the lobes were met, not only zeros compared
    }
    // Lambertian transmission has T / pi from both sides: its adjoint is T / pi, not the
    // (n1 / n2)^2 T / pi that generalised reciprocity would give a physical diffuser.
    const SurfaceContext c = contextAt(30.0, 0.0, 1.0, 1.5);
    const Vec3 out = -polar(b, deg(10.0), 1.0);
    EXPECT_DOUBLE_EQ(lambert.bsdf(c, out, TransportMode::Importance), 0.4 / kPi);
    EXPECT_DOUBLE_EQ(lambert.bsdf(c, out, TransportMode::Flux), 0.4 / kPi);
}

// Specular Transmission: The n^2 Rule

// d(projected solid angle after refraction) / d(projected solid angle before), from finite
// differences of refract(): projected solid angle is area in the plane of the direction's
// tangential components, so this is the determinant of their 2 x 2 Jacobian.
double projectedSolidAngleRatio(const SurfaceContext& c) {
    const Basis b = basisOf(c.normal);
    auto tangential = [&](const Vec3& w) { return Vec2(glm::dot(w, b.t1), glm::dot(w, b.t2)); };
    auto refracted = [&](const Vec2& beta) {
        const Vec3 d =
            beta.x * b.t1 + beta.y * b.t2 - std::sqrt(1.0 - glm::dot(beta, beta)) * c.normal;
        return tangential(*refract(d, c.normal, c.n1, c.n2));
    };
    const Vec2 beta = tangential(c.direction);
    const double h = 1e-6;
    const Vec2 dx = (refracted(beta + Vec2(h, 0)) - refracted(beta - Vec2(h, 0))) / (2 * h);
    const Vec2 dy = (refracted(beta + Vec2(0, h)) - refracted(beta - Vec2(0, h))) / (2 * h);
    return dx.x * dy.y - dx.y * dy.x;
}

TEST(TransportMode, SpecularTransmitWeightCarriesTheRadianceRatio) {
    const OpticalProperty props[] = {
        OpticalProperty::uncoated(),
        OpticalProperty("mgf2", QuarterWaveSpecular{1.38, 550.0}),
        OpticalProperty("fixed", FixedSpecular{0.04, 0.9}),
        OpticalProperty("rough", FresnelSpecular{}, LambertianScatter{0.02, 0.03}),
    };
    int checked = 0;
    for (const OpticalProperty& p : props) {
        for (const auto& [n1, n2] :
             {std::pair(1.0, 1.5), std::pair(1.5, 1.0), std::pair(1.0, 1.9)}) {
            for (double a : {0.0, 20.0, 40.0, 60.0, 80.0}) {
                SurfaceContext c = contextAt(a, 35.0, n1, n2);
                c.wavelengthNm = 500.0;
                const std::optional<Vec3> t = refract(c.direction, c.normal, n1, n2);
                if (!t) {  // TIR: no light comes through from the other side
                    EXPECT_EQ(p.specularTransmitWeight(c, TransportMode::Importance), 0.0);
                    continue;
                }
                const double forward = p.specularTransmitWeight(c, TransportMode::Flux);
                EXPECT_EQ(forward, p.channels(c).specularTransmit);
                // Light coming back the same way: its transmittance (Stokes: the same).
                const SurfaceContext light = lightContext(c, *t);
                const double tLight = p.channels(light).specularTransmit;
                EXPECT_NEAR(tLight, forward, 1e-12) << p << " " << c;
                // Backward: the radiance behind the surface is T times the projected solid
                // angle ratio (n1 / n2)^2, measured here by finite differences.
                const double ratio = projectedSolidAngleRatio(c);
                EXPECT_NEAR(ratio, (n1 / n2) * (n1 / n2), 1e-7);
                const double backward = p.specularTransmitWeight(c, TransportMode::Importance);
                EXPECT_NEAR(backward, tLight * ratio, 1e-7 * tLight) << p << " " << c;
                // Generalised reciprocity of the delta: n2^2 w_importance = n1^2 w_radiance.
                EXPECT_NEAR(n2 * n2 * backward, n1 * n1 * forward, 1e-12 * n1 * n1) << p;
                // Reflection needs no factor: both modes agree.
                EXPECT_NEAR(p.specularReflectWeight(c, TransportMode::Importance),
                            p.specularReflectWeight(c, TransportMode::Flux), 1e-12);
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 40);
    // Opaque parts transmit nothing in either mode.
    SurfaceContext opaque = contextAt(10.0, 0.0, 1.0, 1.0);
    opaque.opaque = true;
    EXPECT_EQ(OpticalProperty::uncoated().specularTransmitWeight(opaque, TransportMode::Importance),
              0.0);
}

// Energy

TEST(TransportMode, BsdfCosineIntegratesToTheChannelFraction) {
    // Broad lobes, so that uniform hemisphere sampling has a small variance.
    const OpticalProperty props[] = {
        OpticalProperty("lambert", FresnelSpecular{}, LambertianScatter{0.25, 0.4}),
        OpticalProperty("gauss", FresnelSpecular{}, GaussianScatter(0.2, 0.3, 30.0)),
        OpticalProperty("abg", FresnelSpecular{},
                        AbgScatter(AbgParams{0.02, 0.05, 2.0}, AbgParams{0.03, 0.08, 2.0})),
    };
    uint64_t seed = 100;
    for (const OpticalProperty& p : props) {
        // The Gaussian lobe's bsdf integrates its mass above the horizon at every call (slow).
        const int n = std::holds_alternative<GaussianScatter>(p.scatter()) ? 50000 : 200000;
        for (double a : {10.0, 50.0}) {
            const SurfaceContext c = contextAt(a, 70.0, 1.0, 1.5);
            const Channels ch = p.channels(c);
            for (const bool transmit : {false, true}) {
                const double fraction = transmit ? ch.scatterTransmit : ch.scatterReflect;
                const Vec3 side = transmit ? -kNormal : kNormal;
                // Flux: over the outgoing directions of this step.
                const Estimate e = hemisphereIntegral(side, n, ++seed, [&](const Vec3& w) {
                    return p.bsdf(c, w, TransportMode::Flux) * std::abs(glm::dot(w, kNormal));
                });
                EXPECT_LT(std::abs(e.z(fraction)), 4.0) << p << " " << a << ": " << e;
                EXPECT_LT(e.sigma, 0.01 * fraction) << p << ": " << e;
                // Importance: for the backward step that leaves along `out`, the integral over
                // the directions it can arrive from of f* cos(arrival) is the fraction the
                // light arriving along -out gives to this channel.
                // (Half the angle: light from the glass at 25 deg is not totally reflected.)
                const Vec3 out = transmit ? -polar(basisOf(kNormal), deg(0.5 * a), 2.0)
                                          : polar(basisOf(kNormal), deg(0.5 * a), 2.0);
                const SurfaceContext lightAt = lightContext(contextFrom(-kNormal, 1.0, 1.5), out);
                const Channels lightCh = p.channels(lightAt);
                const double lightFraction =
                    transmit ? lightCh.scatterTransmit : lightCh.scatterReflect;
                const Estimate imp = hemisphereIntegral(-kNormal, n, ++seed, [&](const Vec3& v) {
                    const SurfaceContext back = contextFrom(v, 1.0, 1.5);
                    return p.bsdf(back, out, TransportMode::Importance) *
                           std::abs(glm::dot(v, kNormal));
                });
                EXPECT_LT(std::abs(imp.z(lightFraction)), 4.0)
                    << p << " " << a << " transmit " << transmit << ": " << imp << " vs "
                    << lightFraction;
                EXPECT_LT(imp.sigma, 0.01 * lightFraction) << p << ": " << imp;
            }
        }
    }
}

TEST(TransportMode, PrintsItself) {
    std::ostringstream os;
    os << TransportMode::Flux << " " << TransportMode::Importance;
    EXPECT_EQ(os.str(), "flux importance");
}

}  // namespace
}  // namespace veil
