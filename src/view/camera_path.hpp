#pragma once
/// @file camera_path.hpp
/// @brief The scene's camera at a frame (scenes/README.md, "camera"): a turntable around the
/// shapes' bounds, a fixed look-at, or keyframes interpolated.

#include "base/types.hpp"
#include "render/camera.hpp"
#include "sim/scene.hpp"

namespace dgv {

/// The camera of `scene` at `frame` (a fraction between frames: a motion blur sample) for an
/// image of the given aspect (width / height); bounds: the shapes' bounds at rest, which a
/// turntable frames.
Camera frameCamera(const SceneDesc& scene, const Box3& bounds, Real frame, Real aspect);

}  // namespace dgv
