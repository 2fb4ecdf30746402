#pragma once
// The lens's designed path, which separates image-forming light from specular stray light in
// a render (docs/render.md, "Image-forming light and stray light").
//
// Image-forming light is light that crossed the lens as it was designed: every optical face
// (lens faces and mirrors, the objects with a prescription surface) once, in prescription
// order, refracting at lens faces and reflecting at mirrors, and nothing else: no ghost
// reflection, no total internal reflection, no scatter, no face skipped (light that passes
// beside a secondary mirror straight to the sensor is stray light). The source's image in the
// field is such light; ghosts and sneak paths are the specular stray light; everything that
// scattered is the scattered stray light.
//
// A branch carries its step on the path: the faces it has crossed as designed (forward, from
// 0 up; backward, from the detector, from steps() down), or kOff once it has left the path.

#include <algorithm>
#include <utility>
#include <vector>

#include "geometry/scene.h"
#include "tracer/records/path_history.h"

namespace veil {

class DesignedPath {
  public:
    static constexpr int kOff = -1;

    DesignedPath() = default;
    explicit DesignedPath(const Scene& scene) {
        stepOfObject_.assign(scene.objects().size(), kOff);
        std::vector<std::pair<int, int>> faces;  // (prescription surface, object)
        for (const SceneObject& o : scene.objects())
            if ((o.kind == ObjectKind::LensFace || o.kind == ObjectKind::MirrorFace) &&
                o.sequentialSurface >= 0)
                faces.emplace_back(o.sequentialSurface, o.id);
        std::sort(faces.begin(), faces.end());
        mirror_.assign(scene.objects().size(), false);
        for (size_t i = 0; i < faces.size(); ++i) {
            const int id = faces[i].second;
            stepOfObject_[static_cast<size_t>(id)] = static_cast<int>(i);
            mirror_[static_cast<size_t>(id)] = scene.object(id).kind == ObjectKind::MirrorFace;
        }
        steps_ = static_cast<int>(faces.size());
        objectOfStep_.reserve(faces.size());
        for (const auto& [surface, id] : faces) objectOfStep_.push_back(id);
    }

    int steps() const { return steps_; }
    // The step of `object`'s face, or kOff for an object off the path.
    int stepOf(int object) const {
        if (object < 0 || static_cast<size_t>(object) >= stepOfObject_.size()) return kOff;
        return stepOfObject_[static_cast<size_t>(object)];
    }
    // The face of step `step` (0 <= step < steps()), and the event that crosses it as designed.
    int objectOfStep(int step) const { return objectOfStep_[static_cast<size_t>(step)]; }
    EventType eventOfStep(int step) const {
        return mirror_[static_cast<size_t>(objectOfStep(step))] ? EventType::SpecularReflect
                                                                : EventType::Refract;
    }

    // Forward: the step after an event of type `e` at `object` by a branch at step `at`.
    int forward(int at, int object, EventType e) const {
        if (at == kOff || at >= steps_) return kOff;
        return isStep(at, object, e) ? at + 1 : kOff;
    }
    // Backward (from the detector toward the source): the step after the event of type `e`
    // (the forward-order event) at `object` by a branch at step `at`.
    int backward(int at, int object, EventType e) const {
        if (at == kOff || at <= 0) return kOff;
        return isStep(at - 1, object, e) ? at - 1 : kOff;
    }
    // A forward branch reaching the detector at step `at`, or a backward one reaching its
    // source: whether its light is image-forming.
    bool completeForward(int at) const { return steps_ > 0 && at == steps_; }
    bool completeBackward(int at) const { return steps_ > 0 && at == 0; }

  private:
    bool isStep(int step, int object, EventType e) const {
        if (object < 0 || static_cast<size_t>(object) >= stepOfObject_.size()) return false;
        if (stepOfObject_[static_cast<size_t>(object)] != step) return false;
        return mirror_[static_cast<size_t>(object)] ? e == EventType::SpecularReflect
                                                    : e == EventType::Refract;
    }

    std::vector<int> stepOfObject_;
    std::vector<int> objectOfStep_;
    std::vector<bool> mirror_;
    int steps_ = 0;
};

}  // namespace veil
