#pragma once
/// @file scene_json.hpp
/// @brief Scene files (JSON; schema in scenes/README.md) read into a validated SceneDesc.
///
/// Everything is checked up front: the first problem throws InputError(file, json path, what),
/// e.g. "scenes/a.json: objects[1].voxel_size: expected a positive number, got -1". Unknown keys
/// are errors (they are usually typos; the message suggests the closest known key). Relative
/// input paths (meshes) resolve against the scene file's folder; the output folder resolves
/// against the working directory, or against the scene's folder when it starts with "//".

#include "sim/scene.hpp"

#include <filesystem>
#include <string>

namespace dgv {

/// Reads and validates a scene file.
SceneDesc loadScene(const std::filesystem::path& path);

/// Same, from text; `path` names the input in messages and anchors relative paths.
SceneDesc parseScene(const std::string& text, const std::filesystem::path& path);

}  // namespace dgv
