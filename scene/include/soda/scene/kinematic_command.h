// scene/ — how an input becomes a kinematic body's command, and how a body
// keeps its commands (docs/scene-format.md, "Kinematic bodies"): the one
// rule every world and the runtime's census follow, so that all of them
// hold the same commands.
#pragma once

#include <algorithm>
#include <vector>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda {

/// The command a set_pose (a teleport) or set_kinematic_target input gives.
inline KinematicCommand kinematic_command(const UserInput& in) {
  return KinematicCommand{in.step, in.kind == UserInput::Kind::SetPose, Pose{in.linear, in.orientation}};
}

/// Adds `command` to `commands` (ascending step): one command per step, a
/// later one at the same step replacing the earlier.
inline void record_kinematic_command(std::vector<KinematicCommand>& commands, const KinematicCommand& command) {
  auto at = std::lower_bound(commands.begin(), commands.end(), command.step,
                             [](const KinematicCommand& x, std::int64_t step) { return x.step < step; });
  if (at != commands.end() && at->step == command.step)
    *at = command;
  else
    commands.insert(at, command);
}

}  // namespace soda
