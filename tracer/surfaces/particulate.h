#pragma once
// Scatter from particulate contamination (dust) at an IEST-STD-CC1246 cleanliness level.
//
// The size distribution (IEST-STD-CC1246E): at level L, the number of particles of diameter
// D um or larger on 0.1 m^2 of surface is
//
//     log10 N(D) = 0.926 (log10^2 L - log10^2 D),   1 <= D <= L (one particle of size L),
//
// counted here from minUm (1 um by default) to L. Its percent area coverage (the particles'
// projected area) is close to the fit PAC = 10^(-7.245 + 0.926 log10^2 L) % (cc1246Pac).
//
// Each particle is a sphere of refractive index index + i k (tracer/surfaces/mie.h). The
// distribution is cut into bins of 12 per octave of diameter, each counted exactly from N(D) and
// computed with Mie theory at its geometric centre: the sums over the bins give, per unit area of
// surface, the extinction and scattering cross sections C_ext = sum N sigma_ext and C_sca
// (dimensionless: area of cross section per area of surface) and the ensemble's phase
// function p(mu) (normalised over the sphere), tabulated at 1501 scattering angles
// theta_k = pi (k / 1500)^2 (fine near the forward direction, where large particles
// diffract) and interpolated linearly in mu = cos(theta).
//
// The surface model (OpticalProperty, ParticulateScatter): independent particles, single
// scatter, in the lower-index medium on the surface (air, on a lens or a mount). Light that
// meets them at angle theta to the normal finds the share
//
//     f_ext = 1 - exp(-C_ext / cos(theta))       (random particles; C_ext / cos theta when sparse)
//
// of the beam intercepted: f_ext (C_sca / C_ext) is scattered, the rest absorbed; the
// specular light that passes the dust is 1 - f_ext of what it would be. Scattered light
// leaves with the phase function about its direction: on the dust's side directly, into the
// other medium refracted (all of it enters when that medium is denser; the bare interface's
// reflection of it is left out). So the BSDF on the dust's side is
//
//     BSDF = f_ext (C_sca / C_ext) p(mu) / cos(s)        (sparse: C_sca p / (cos(i) cos(s)))
//
// and on the other side (n_high / n_low)^2 times that at the direction refraction maps. On a
// substrate that takes no light in (opaque, or a mirror or absorbing coating: no specular
// transmission) the forward light does not cross; where it reflects (r > 0) the image paths
// are added: the dust's
// forward light that the substrate reflects, and the reflected beam's forward scatter on its
// way out (r (2 - f_ext) f_ext (C_sca / C_ext) (1 - back), a lobe of the phase function about
// the mirror direction; the specular beam crosses the dust twice, (1 - f_ext)^2 r). Left
// out: the image paths of transparent surfaces (the bare interface's few percent), shadowing
// between particles, and multiple scatter; on a substrate that neither transmits nor
// reflects specularly the forward-scattered light is absorbed.

#include <atomic>
#include <complex>
#include <cstdint>
#include <memory>
#include <mutex>
#include <ostream>
#include <vector>

#include "geometry/vec.h"

namespace veil {

struct ParticulateParams {
    double level = 0.0;  // IEST-STD-CC1246 cleanliness level L, in [1, 1000]
    double minUm = 1.0;  // smallest diameter counted, in (0, L)
    double index = 1.5;  // the particles' refractive index, real part (> 0)
    double k = 0.0;      // and imaginary part (>= 0: absorption)
};
std::ostream& operator<<(std::ostream& os, const ParticulateParams& p);

// Particles of diameter >= dUm per 0.1 m^2 at level L (IEST-STD-CC1246); 0 past L.
double cc1246Count(double level, double dUm);
// The standard's fit of the percent area coverage at level L.
double cc1246Pac(double level);

// The ensemble at one wavelength in the medium around the particles.
class ParticulateEnsemble {
  public:
    // wavelengthUm in the medium (vacuum wavelength / mediumIndex).
    ParticulateEnsemble(const ParticulateParams& p, double wavelengthUm, double mediumIndex);

    double extinction() const { return cExt_; }  // C_ext, per unit area
    double scattering() const { return cSca_; }  // C_sca
    double coverage() const { return cGeo_; }    // projected area per unit area (PAC / 100)
    double albedo() const { return cExt_ > 0.0 ? cSca_ / cExt_ : 0.0; }
    // The phase function at mu (per steradian, integral over the sphere 1).
    double phase(double mu) const;
    // The share of the phase function in the hemisphere that faces the light's source, for
    // light arriving at incidence angle theta (cos theta = cosIn) on a surface: directions d
    // with dot(d, n) > 0 where dot(incoming, n) = -cosIn. From a table over theta.
    double backShare(double cosIn) const;
    double backShareExact(double cosIn) const;  // by quadrature (the table's reference)
    // A direction about `incoming` (unit) with density phase(mu) over the sphere.
    Vec3 sample(const Vec3& incoming, double u1, double u2) const;
    // The tries of a rejection loop that keeps the directions sample(incoming, u1, u2) on one
    // side of a plane: dot(direction, normal) > 0 when `above`, < 0 otherwise. The frame about
    // `incoming` is set up once, and a try whose polar angle alone puts the whole cone of
    // azimuths on the wrong side (by far more than rounding) is refused before the azimuth is
    // drawn; the others are sample()'s direction bit for bit. For a forward-peaked phase
    // function kept on the backward side most tries end at the first test.
    class SideSampler {
      public:
        SideSampler(const ParticulateEnsemble& e, const Vec3& incoming, const Vec3& normal,
                    bool above);
        // True when sample(incoming, u1, u2) lies on the side, written to `out`.
        bool attempt(double u1, double u2, Vec3& out) const;

      private:
        const ParticulateEnsemble& e_;
        Vec3 incoming_, normal_, t1_, t2_;
        bool above_;
        double along_, across_;  // incoming . normal, |(t1 . normal, t2 . normal)|
    };

    const std::vector<double>& mu() const { return mu_; }  // the table's nodes, ascending

  private:
    double sampleMu(double u) const;

    double cExt_ = 0.0, cSca_ = 0.0, cGeo_ = 0.0;
    std::vector<double> mu_, p_, cdf_;  // ascending mu; cdf over mu (times 2 pi)
    std::vector<double> back_;          // backShare at cos(theta) = 0 .. 1 in 1200 steps
    // guide_[g]: the first node whose cdf exceeds g / kGuideBuckets (cdf_.size() if none), so
    // that sampleMu() searches a few nodes instead of all of them.
    static constexpr int kGuideBuckets = 1024;
    std::vector<uint32_t> guide_;
};

// The property's scatter model: the parameters and the ensembles, computed once per
// (wavelength, medium) and shared by copies.
class ParticulateScatter {
  public:
    // Throws std::invalid_argument for parameters out of range.
    explicit ParticulateScatter(const ParticulateParams& p);

    const ParticulateParams& params() const { return p_; }
    // The ensemble at this vacuum wavelength in a medium of this index (computed on first
    // use: a second or so for large particles at short wavelengths; a thread asking for one
    // being computed waits for it rather than computing it again). It lives as long as this
    // model or any copy of it. Finding one already computed takes no lock and writes no
    // shared memory: the transport asks at every event on a dusty face, from every thread.
    const ParticulateEnsemble* at(double wavelengthNm, double mediumIndex) const;

  private:
    // The ensembles computed so far: a list, newest first, published once an entry is
    // written (release) and read without a lock (acquire); the mutex orders the writers,
    // and `owned` (written under it, never read by the readers) holds every entry.
    struct Entry {
        double wavelengthNm, mediumIndex;
        std::unique_ptr<const ParticulateEnsemble> ensemble;
        const Entry* next;
    };
    struct Cache {
        std::mutex writing;
        std::vector<std::unique_ptr<const Entry>> owned;
        std::atomic<const Entry*> newest{nullptr};
        const ParticulateEnsemble* find(double wavelengthNm, double mediumIndex) const;
    };
    ParticulateParams p_;
    std::shared_ptr<Cache> cache_;
};

}  // namespace veil
