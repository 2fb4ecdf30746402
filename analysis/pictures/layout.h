#pragma once
// 2D layout: the y-z section of lens elements, mechanics, stop and detector, with the
// optical axis, part labels, the light sources, a scale bar and a legend of what is drawn.
//
//   Scene ──sceneSection──> filled parts ─┐
//   tracer Sources ──layoutSources(scene)─┴─ drawLayout ──> Picture (more layers on top later)
//
// Glass is filled light blue, mirrors light grey, mechanical parts grey, the stop black,
// imported meshes olive; a detector is a red line labelled with its object name; sources
// are orange arrows (and an orange dot or bar where a point or an area emits). A 3D point
// (x, y, z) is drawn at (z, y), as in ray path pictures.

#include <ostream>
#include <string>
#include <vector>

#include "analysis/pictures/picture.h"
#include "tracer/light/source.h"
#include "tracer/records/detector.h"

namespace veil {

class Scene;
class SequentialModel;

// A light source as a layout draws it: a few of its rays as arrows in the y-z plane, and the
// emitter's section. Points are (z, y) in global mm.
struct LayoutSource {
    struct Arrow {
        Vec2 fromZY{0.0}, toZY{0.0};
    };
    std::string name;             // drawn beside the source
    std::string kind;             // "collimated", "sun", "point", "window", "lambertian"
    std::vector<Vec2> emitterZY;  // point: its position; window, lambertian: the ends of
                                  // the emitting area's section; beams: empty
    std::vector<Arrow> arrows;    // from where the ray is drawn to start to where it ends
    // Drawn after the name: "7 deg off axis" (a beam's angle to +z), "+-3.25 deg cone" (a
    // point or window source's half-angle); empty for a beam along +z and a Lambertian panel.
    std::string detail;
};
std::ostream& operator<<(std::ostream& os, const LayoutSource& s);

struct LayoutSourceOptions {
    int beamRays = 7;  // parallel arrows across a collimated or sun beam (>= 1)
    int coneRays = 5;  // arrows across a point source's cone (>= 1)
    // Shortest arrow of a beam (mm); 0: 8 % of the scene's larger extent (z or y).
    double minBeamArrowMm = 0.0;
};

// The sources as a layout draws them, each ray traced in 3D to the first scene object it
// meets (where its arrow ends; a ray that meets nothing runs past the scene's bounds and
// is clipped to the layout's frame):
//   collimated, sun  beamRays parallel rays across the start disk, in the plane of the beam
//                    direction and the disk's direction closest to +y. A beam comes from
//                    infinity: its arrows start on a line parallel to the start disk, set back
//                    from it as far as needed for the shortest arrow to be minBeamArrowMm long
//                    (the default start gap is 5 mm, too short to see). The sun's 0.27 deg
//                    spread is not drawn.
//   point            the position and coneRays rays spread evenly over 90 % of the cone's
//                    section in the plane of its axis and +y (the edge of a cone that just
//                    covers the first surface grazes the rim and flies past it).
//   window,          the section of the emitting disk or rectangle through its centre along
//   lambertian       its in-plane direction closest to +y, rays along the normal from its
//                    ends and centre, and two from the centre at +-the cone half-angle (at
//                    most 45 deg drawn).
// `scene` must be committed (Scene::commit(); a PreparedScene's is). The CLI passes
// prepared->transport().view.sources.
std::vector<LayoutSource> layoutSources(const std::vector<Source>& sources, const Scene& scene,
                                        const LayoutSourceOptions& options = {});

// A detector's recorded area as a layout draws it: its pixel grid's rectangle
// (tracer/records/detector.h) cut by the section plane x = 0, as the segment's ends (z, y).
struct LayoutDetector {
    std::string name;
    Vec2 fromZY{0.0}, toZY{0.0};
};
// The grids of the detectors the plane x = 0 cuts (one it misses is left out).
std::vector<LayoutDetector> layoutDetectors(const std::vector<DetectorGeometry>& grids);

struct LayoutOptions {
    double chordToleranceMm = 0.005;  // section sampling of exact faces
    bool labels = true;               // element, detector and source names
    std::string title;
    // Sources to draw (layoutSources()). The frame grows to show where they start, by at
    // most half the section's larger extent on each side; what lies further out is clipped.
    std::vector<LayoutSource> sources;
    // The optical axis through the surfaces' vertices, in order (layoutAxis()); empty: the
    // global z axis across the picture. Drawn from the picture's left edge along z to the
    // first vertex (if that lies inside), then vertex to vertex, each stretch once: a fold
    // shows where the axis turns.
    std::vector<Vec3> axisVerticesMm;
    // The detectors' recorded areas (layoutDetectors()), drawn as thick lines over the sensor
    // surfaces, which are then drawn thin: what records light is the grid, not the whole
    // surface it lies on.
    std::vector<LayoutDetector> detectors;
};

// The vertices of every surface light meets, surface 1 to the image (coordinate breaks left
// out), when a coordinate break takes the system off one axis; empty for a coaxial system.
std::vector<Vec3> layoutAxis(const SequentialModel& model);

// A picture of the scene's section; more layers (ray paths) can be drawn on it afterwards.
// Its legend lists the kinds of part drawn (glass, mirror, mechanics, imported mesh,
// aperture stop, detector, dummy surface), the optical axis, and the sources if any.
Picture drawLayout(const Scene& scene, const LayoutOptions& options);

}  // namespace veil
