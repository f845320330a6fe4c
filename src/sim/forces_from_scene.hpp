#pragma once
/// @file forces_from_scene.hpp
/// @brief The scene's forces (SceneDesc::forces, the field's terms as io/scene_json reads them)
/// as the dynamics' time-dependent force field (dynamics/forces.hpp), with the scene's JSON
/// paths in its errors.

#include "dynamics/forces.hpp"

#include <string>
#include <vector>

namespace dgv {

/// The sum of the scene's forces, evaluated at scene frames. An empty list gives an empty field
/// (F = 0). A term the parser let through but the field rejects throws InputError naming
/// `forces[i].<key>` as the scene file spells it (`centre` is the file's `position`): a bug in
/// the parser's validation, reported as bad input.
ForceField forceFieldFromScene(const std::vector<ForceTerm>& forces, const std::string& sceneFile = "");

}  // namespace dgv
