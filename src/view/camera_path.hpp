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

/// `camera` seen through point k of n of its lens (camera.depth_of_field): the eye moved within
/// the aperture, of radius focal length / (2 f-stop) (the focal length from the field of view on
/// the lens's sensor, 36 mm by default, along the image's longer side), to the k-th point of a
/// Vogel spiral (even over the disc, the same for every frame), its view shifted off axis so that
/// the plane at the focus distance projects where it did.
Camera lensSample(const Camera& camera, const CameraDesc& desc, Real aspect, int k, int n);

}  // namespace dgv
