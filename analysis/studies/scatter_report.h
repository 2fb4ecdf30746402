#pragma once
// What a scene's scatter models do (`veil scatter`): each scattering property's total
// integrated scatter (TIS) against incidence at the scene's wavelengths, its BSDF against
// scatter angle in the plane of incidence, the objects that carry it, and for measured
// tables the TIS their files state beside the table's own integral.
//
// The reflected channel is for light arriving from air (n = 1). The transmitted channel is
// for light going from air into the densest medium next to a lens face that carries the
// property, at each wavelength (n = 1.5 when no lens face carries it; the report says which).
// Opaque parts transmit nothing whatever the model says.

#include <string>
#include <vector>

#include "analysis/pictures/picture.h"
#include "analysis/reports/report_table.h"
#include "tracer/surfaces/property_table.h"

namespace veil {

class Scene;
class SequentialModel;

struct ScatterReportSpec {
    // Properties to report; empty: every property with scatter that an object of the scene
    // carries.
    std::vector<std::string> properties;
    std::vector<double> wavelengthsNm;  // empty: the model's
    std::vector<double> incidencesDeg = {0, 10, 20, 30, 40, 50, 60, 70, 80, 85, 89};
    std::vector<double> plotIncidencesDeg = {0, 30, 60};
};

struct ScatterFileBlock {
    bool transmission = false;
    double angleDeg = 0.0;  // the block's specular angle
    double fileTis = 0.0;   // as the file states it
    double modelTis = 0.0;  // the model's (the table's integral, or scaled to the file)
};

struct ScatterPropertyReport {
    std::string name;
    std::string model;                  // the scatter model as it prints itself
    std::vector<std::string> objects;   // scene objects that carry it
    bool opaqueOnly = false;            // every carrier is opaque: no transmission
    std::vector<double> transmitIndex;  // per wavelength: the n the light enters
    bool indexAssumed = false;          // no lens face carries it: n = 1.5
    // [incidence][wavelength]; transmit is empty when the model has no transmitted channel.
    std::vector<std::vector<double>> reflectTis, transmitTis;
    std::vector<ScatterFileBlock> fileBlocks;
    // Dust (particulate): per wavelength in air, its cross sections per unit area and its
    // projected area against IEST-STD-CC1246's fit.
    std::vector<std::string> notes;
};

struct ScatterReport {
    std::vector<double> wavelengthsNm, incidencesDeg;
    std::vector<ScatterPropertyReport> properties;

    // The tables (analysis/reports/report_table.h): every property's TIS per incidence and
    // wavelength as rows (scatter.csv), one property's TIS against incidence (the Markdown),
    // a measured table's blocks against the model.
    ReportTable tisRows() const;
    ReportTable tisTable(const ScatterPropertyReport& property) const;
    ReportTable fileBlockTable(const ScatterPropertyReport& property) const;
    std::string markdown() const;
    std::string csv() const;  // property, channel, incidence, wavelength, TIS
    std::string json() const;
};

// ModelError naming a --property that is not defined or does not scatter.
ScatterReport scatterReport(const PropertyTable& table, const Scene& scene,
                            const std::vector<int>& propertyOf, const SequentialModel& model,
                            const ScatterReportSpec& spec);

// BSDF (1/sr, log scale) against the scatter angle from the normal in the plane of incidence
// (positive on the specular side), one curve per incidence, for the reflected or transmitted
// channel (into index n2) at one wavelength.
Picture drawBsdfChart(const OpticalProperty& property, bool transmit, double wavelengthNm,
                      double n2, const std::vector<double>& incidencesDeg);
// The BRDFs of several properties at one incidence, one curve each, for comparing them.
Picture drawBrdfComparison(const std::vector<const OpticalProperty*>& properties,
                           double wavelengthNm, double incidenceDeg);
// TIS against incidence of every reported property at wavelength index w.
Picture drawTisChart(const ScatterReport& report, int w);

}  // namespace veil
