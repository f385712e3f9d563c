// Scene validation: every rule a scene must satisfy before any world sees it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

#include "soda/scene/envelope.h"
#include "soda/scene/scene.h"

namespace soda {

/// Bullet disables (DISABLE_SIMULATION, with one console warning) a dynamic
/// body whose AABB for a step has length^2 >= 1e12 (see
/// btDiscreteDynamicsWorld::updateSingleAabb). We refuse such bodies up front.
inline constexpr double kBulletMaxAabbLength2 = 1e12;

/// Bullet indexes a mesh's vertices and a heightfield's samples with int.
inline constexpr std::size_t kMaxMeshVertices = 0x7fffffff;
inline constexpr std::int64_t kMaxHeightfieldSamples = 0x7fffffff;

/// Error in a scene: the message names the source (file or generator), the
/// body (index and id) and the field, e.g.
///   "cubes.json: body #3 (id 17): field 'mass': must be > 0 for a dynamic body".
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The checks of one body that depend on nothing else (shape, finite
/// numbers, friction, restitution, orientation, a dynamic body's mass > 0);
/// `where` starts the message ("cubes.json: body #3 (id 17)").
void validate_body(const Body& body, const std::string& where);

/// The body with an id, or null (for validate_joint).
using BodyLookup = std::function<const Body*(BodyId)>;

/// The checks of one joint: its bodies exist (`body`), are two, not both
/// static; frames, limits, spans, springs and motors finite and in range
/// (docs/scene-format.md, "Joints"). `where` starts the message
/// ("chain.json: joint #3 (id 7)"), and the field is named.
void validate_joint(const Joint& joint, const std::string& where, const BodyLookup& body);

/// Checks every invariant listed in scene.h and the settings (dt > 0, finite
/// gravity, substeps >= 1, iterations >= 1), and that the scene lies inside
/// the precision envelope of `precision` (envelope.h: the step, every
/// body's position, size, mass and spin). Throws SceneError on the first
/// violation; `source` is put at the start of the message. Joints: unique
/// ids, and validate_joint for each. The default,
/// Double, is the widest envelope: what a file or generator may hold at all;
/// a float build checks again with Precision::Float before it runs.
void validate_scene(const Scene& scene, const std::string& source, Precision precision = Precision::Double);

}  // namespace soda
