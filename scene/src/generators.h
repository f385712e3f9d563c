// The scene generators of the registry (definitions: BENCHMARKS.md, docs/scenes.md).
#pragma once

#include "soda/scene/registry.h"

namespace soda::detail {

Scene make_falling_cubes(const SceneParams& params);
Scene make_cube_pile(const SceneParams& params);

}  // namespace soda::detail
