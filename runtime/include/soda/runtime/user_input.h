// runtime/ — user input: what an embedding application does to the scene
// while it runs (add a body, remove one, set a body's velocity, give it an
// impulse), each at a scene step boundary. Inputs are ordered by (step,
// sequence), the sequence being the order of the calls, so the result does
// not depend on when a call was made — only on the step it names. The
// Simulation applies an input for a step some world has already passed by
// rolling every world back to that step (docs/embedding.md, "Input").
#pragma once

#include <cstdint>
#include <string>

#include "soda/scene/scene.h"

namespace soda {

struct UserInput {
  enum class Kind { AddBody, RemoveBody, SetVelocity, ApplyImpulse };
  Kind kind = Kind::SetVelocity;
  /// Applied at the boundary after scene step `step` (0: before the first
  /// step), before step + 1 begins.
  std::int64_t step = 0;
  std::uint64_t sequence = 0;  // call order; ties at one step resolve by it
  Body body;                   // AddBody: the new body (its id must be unused)
  BodyId id = 0;               // RemoveBody, SetVelocity, ApplyImpulse
  Vec3 linear = Vec3::Zero();  // SetVelocity: linear velocity; ApplyImpulse: impulse (N s) at the centre
  Vec3 angular = Vec3::Zero(); // SetVelocity: angular velocity
};

/// "add body 12 at step 40", ...
std::string describe(const UserInput& input);

}  // namespace soda
