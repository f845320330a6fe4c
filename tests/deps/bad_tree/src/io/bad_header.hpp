#pragma once
// A deliberate violation: a third-party header in a dgv header.
#include <assimp/scene.h>
