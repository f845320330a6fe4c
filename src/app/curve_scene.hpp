#pragma once
/// @file curve_scene.hpp
/// @brief `dgv render` of a scene with curves (scenes/README.md, "curves"): the seed's figures
/// 1-4 (section 5). Per frame: both curves drawn as tubes to <out>/<name>.####.png, and their
/// closest approach, the seed method's GLN at each scene tolerance and the certified exact GLN
/// to <out>/gln.csv; then three plots: gln_distance.png (distance vs frame), gln_frame.png (GLN
/// vs frame) and gln_vs_distance.png (GLN vs distance).

#include "base/types.hpp"
#include "render/renderer.hpp"
#include "sim/scene.hpp"

#include <vector>

namespace dgv::app {

/// The curve's vertices at rest (a ring or the curve file), before its motion. InputError for a
/// bad curve file.
std::vector<Vec3> curveAtRest(const CurveDesc& curve);

/// Renders frames [first, last] of a curve scene with `settings` (renderSettingsOf) and writes
/// gln.csv and the plots. Exit code.
int renderCurveScene(const SceneDesc& scene, const RenderSettings& settings, int first, int last);

/// The renderer's settings from a scene's `render` block.
RenderSettings renderSettingsOf(const RenderDesc& desc, GlBackend backend);

}  // namespace dgv::app
