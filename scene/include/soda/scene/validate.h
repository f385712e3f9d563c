// Scene validation: every rule a scene must satisfy before any world sees it.
#pragma once

#include <stdexcept>
#include <string>

#include "soda/scene/scene.h"

namespace soda {

/// Bullet disables (DISABLE_SIMULATION, with one console warning) a dynamic
/// body whose AABB for a step has length^2 >= 1e12 (see
/// btDiscreteDynamicsWorld::updateSingleAabb). We refuse such bodies up front.
inline constexpr double kBulletMaxAabbLength2 = 1e12;

/// Error in a scene: the message names the source (file or generator), the
/// body (index and id) and the field, e.g.
///   "cubes.json: body #3 (id 17): field 'mass': must be > 0 for a dynamic body".
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Checks every invariant listed in scene.h and the settings (dt > 0, finite
/// gravity, substeps >= 1, iterations >= 1). Throws SceneError on the first
/// violation; `source` is put at the start of the message.
void validate_scene(const Scene& scene, const std::string& source);

}  // namespace soda
