#include "tracer/surfaces/scatter_tabulation.h"

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "lensdata/zemax_bsdf.h"

namespace veil {

namespace {
constexpr double kDeg = std::numbers::pi / 180.0;
}

std::ostream& operator<<(std::ostream& os, const TabulationGrid& g) {
    return os << "TabulationGrid{" << g.incidenceDeg.size() << " incidences, "
              << g.azimuthDeg.size() << " azimuths, " << g.radialDeg.size() << " radial angles"
              << (g.planeSymmetric ? ", plane-symmetric" : "") << "}";
}

SurfaceContext incidenceContext(double incidenceDeg, double wavelengthNm, double n1, double n2,
                                bool opaque) {
    const double i = incidenceDeg * kDeg;
    SurfaceContext c;
    c.normal = Vec3(0.0, 0.0, 1.0);
    c.direction = Vec3(std::sin(i), 0.0, -std::cos(i));
    c.n1 = n1;
    c.n2 = n2;
    c.wavelengthNm = wavelengthNm;
    c.opaque = opaque;
    return c;
}

TabulationGrid exportGrid() {
    TabulationGrid g;
    for (int a = 0; a <= 80; a += 10) g.incidenceDeg.push_back(a);
    g.incidenceDeg.push_back(85.0);
    g.incidenceDeg.push_back(89.0);
    for (int a = 0; a <= 180; a += 10) g.azimuthDeg.push_back(a);
    for (int r = 0; r < 20; ++r) g.radialDeg.push_back(0.25 * r);
    for (int r = 5; r < 30; ++r) g.radialDeg.push_back(r);
    for (int r = 30; r <= 180; r += 5) g.radialDeg.push_back(r);
    return g;
}

ZemaxBsdf tabulateScatter(const OpticalProperty& property, bool transmit,
                          const TabulationGrid& grid, double wavelengthNm, double n1, double n2) {
    if (grid.azimuthDeg.size() < 2 || grid.radialDeg.size() < 2 || grid.incidenceDeg.empty())
        throw std::invalid_argument("a tabulation grid needs incidences, azimuths and radii");
    ZemaxBsdf d;
    d.planeSymmetric = grid.planeSymmetric;
    d.transmission = transmit;
    d.azimuthDeg = grid.azimuthDeg;
    d.radialDeg = grid.radialDeg;
    std::ostringstream note;
    note << "Wavelength (nm) = " << wavelengthNm << "; light from index " << n1 << " to " << n2;
    d.comments = {"Written by veil from the property '" + property.name() + "'", note.str()};
    // The surface: normal +z, the light arriving in the x-z plane from -x (specular
    // direction leaning to +x), the frame of tracer/surfaces/tabulated_bsdf.h.
    const Vec3 normal(0.0, 0.0, 1.0);
    for (double specularDeg : grid.incidenceDeg) {
        const double ts = specularDeg * kDeg;
        // The incidence whose specular direction leaves at ts.
        double sinI = std::sin(ts);
        if (transmit) sinI = n2 / n1 * std::sin(ts);
        if (sinI >= 1.0) continue;
        const double cosI = std::sqrt(1.0 - sinI * sinI);
        SurfaceContext c;
        c.normal = normal;
        c.direction = Vec3(sinI, 0.0, -cosI);
        c.n1 = n1;
        c.n2 = n2;
        c.wavelengthNm = wavelengthNm;
        const Channels ch = property.channels(c);
        ZemaxBsdfBlock b;
        b.incidenceDeg = specularDeg;
        b.fileTis = transmit ? ch.scatterTransmit : ch.scatterReflect;
        const double side = transmit ? -1.0 : 1.0;
        const Vec3 s(std::sin(ts), 0.0, side * std::cos(ts));
        const Vec3 sideNormal = side * normal;
        Vec3 u = sideNormal - glm::dot(sideNormal, s) * s;
        u = glm::length(u) > 1e-12 ? glm::normalize(u) : Vec3(-1.0, 0.0, 0.0) * side;
        const Vec3 v = glm::cross(s, u);
        for (double az : grid.azimuthDeg)
            for (double rad : grid.radialDeg) {
                const double r = rad * kDeg, phi = az * kDeg;
                const Vec3 out = glm::normalize(
                    std::cos(r) * s + std::sin(r) * (std::cos(phi) * u + std::sin(phi) * v));
                b.values.push_back(glm::dot(out, sideNormal) > 0.0 ? property.bsdf(c, out) : 0.0);
            }
        d.blocks.push_back(std::move(b));
    }
    if (d.blocks.empty())
        throw std::invalid_argument("no incidence of the grid reaches the channel");
    return d;
}

}  // namespace veil
