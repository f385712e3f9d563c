// scene/ — how an input becomes a kinematic body's command, and how a body
// keeps its commands (docs/scene-format.md, "Kinematic bodies"): the one
// rule every world and the runtime's census follow, so that all of them
// hold the same commands.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda {

/// The command a set_pose (a teleport) or set_kinematic_target input gives.
inline KinematicCommand kinematic_command(const UserInput& in) {
  return KinematicCommand{in.step, in.kind == UserInput::Kind::SetPose, Pose{in.linear, in.orientation}};
}

/// The first command of `commands` (ascending step) at or after `step`.
template <typename Command>
typename std::vector<Command>::iterator command_at(std::vector<Command>& commands, std::int64_t step) {
  return std::lower_bound(commands.begin(), commands.end(), step,
                          [](const Command& x, std::int64_t s) { return x.step < s; });
}

/// Adds `command` (a KinematicCommand or a FilterCommand) to `commands`
/// (ascending step): one command per step, a later one at the same step
/// replacing the earlier.
template <typename Command>
void record_command(std::vector<Command>& commands, const Command& command) {
  auto at = command_at(commands, command.step);
  if (at != commands.end() && at->step == command.step)
    *at = command;
  else
    commands.insert(at, command);
}

/// Merges `from` into `into` (both ascending step): a command of a step
/// `into` has is kept. Commands are keyed by step and never change, so
/// two worlds' lists never disagree on a step both hold.
template <typename Command>
void merge_commands(std::vector<Command>& into, const std::vector<Command>& from) {
  for (const Command& c : from) {
    auto at = command_at(into, c.step);
    if (at == into.end() || at->step != c.step) into.insert(at, c);
  }
}

/// True if inputs gave kinematic body `body` a command, pose or filter: its
/// state at a step is no longer the scene's alone.
inline bool commanded(const Body& body) { return !body.commands.empty() || !body.filter_commands.empty(); }

/// A body's collision filter (group, mask) at internal step n, before the
/// inputs of that boundary, with `substeps` internal steps a scene step: a
/// kinematic body's last filter command of a boundary below n (step *
/// substeps < n), else the body's own. (A world built at internal step n
/// takes these; those of boundary n are its inputs there, applied when it
/// steps on.)
inline std::pair<std::uint32_t, std::uint32_t> collision_filter_before(const Body& body, std::int64_t n,
                                                                        std::int64_t substeps) {
  const auto after = std::partition_point(body.filter_commands.begin(), body.filter_commands.end(),
                                          [&](const FilterCommand& c) { return c.step * substeps < n; });
  if (after == body.filter_commands.begin()) return {body.collision_group, body.collision_mask};
  return {(after - 1)->group, (after - 1)->mask};
}

}  // namespace soda
