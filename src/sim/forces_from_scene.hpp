#pragma once
/// @file forces_from_scene.hpp
/// @brief The scene's forces (sim/scene.hpp ForceDesc, validated by io/scene_json) as the
/// dynamics' time-dependent force field (dynamics/forces.hpp).

#include "dynamics/forces.hpp"
#include "sim/scene.hpp"

#include <vector>

namespace dgv {

/// One scene force as a force term: `position` becomes the centre, the strength keys are copied
/// (same interpolation rule), every other setting maps one to one.
ForceTerm forceTermFromScene(const ForceDesc& desc);

/// The sum of the scene's forces, evaluated at scene frames. An empty list gives an empty field
/// (F = 0). A force the parser let through but the field rejects throws InputError naming
/// `forces[i].<field>` (a bug in the parser's validation, reported as bad input).
ForceField forceFieldFromScene(const std::vector<ForceDesc>& forces, const std::string& sceneFile = "");

}  // namespace dgv
