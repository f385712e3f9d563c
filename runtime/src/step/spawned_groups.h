// Internal: where a group spawned at one step boundary lives (bodies added
// and joined at that boundary by added joints; docs/partitioned-step.md,
// "Joints"). Every world computes the same from the boundary's inputs.
#pragma once

#include <map>
#include <vector>

#include "soda/runtime/user_input.h"

namespace soda {

/// For each body added by `inputs` (one boundary's, in sequence order) and
/// joined by them to another added body: its group's home, the position
/// its anchor's (smallest id's) add_body input gives.
std::map<BodyId, Vec3> spawned_group_homes(const std::vector<UserInput>& inputs);

}  // namespace soda
