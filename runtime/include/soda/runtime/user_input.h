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

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda {

// struct UserInput lives with the input file format (scene/input_file.h),
// which `soda run --inputs` reads.

/// "add body 12 at step 40", ...
std::string describe(const UserInput& input);

}  // namespace soda
