// Internal: run_scene with user inputs (RunConfig::inputs): the scene on a
// Simulation, the inputs given through its input calls before it starts.
#pragma once

#include "soda/runtime/run.h"

namespace soda {
namespace replay {
class ReplayWriter;
}

/// Describes to a replay file the bodies config.inputs add (it stores a
/// body's description before the first frame that holds it): every
/// recording, on threads and over ranks, before its first frame.
void describe_added_bodies(replay::ReplayWriter& out, const RunConfig& config);

/// The checkpoint options (--checkpoint, --resume) of `config`: a
/// Simulation's features only, the step within the run's steps, no
/// --record. Throws std::invalid_argument naming the option.
void check_checkpoints(const RunConfig& config);

/// Whether run_scene replays config.inputs through a Simulation (the
/// embedding API's calls): yes unless config.inputs_via_simulation is
/// false or the run balances load (a policy other
/// than "none"), runs SyncTest or heals, which a Simulation does not do;
/// those runs give the inputs to the PartitionedWorld
/// (PartitionedOptions::inputs), which ends on the same hash.
bool inputs_through_simulation(const RunConfig& config);

/// Whether config asks for what only a Simulation does: --record,
/// --checkpoint, --resume.
bool through_simulation_only(const RunConfig& config);

/// run_scene when config.inputs is set and inputs_through_simulation, or
/// through_simulation_only (validated there first): with a record path,
/// a SceneReader on the calling thread reads every committed frame into the
/// replay file while the worlds run (bodies the inputs add and remove come
/// and go in its frames); with a checkpoint path the run writes a checkpoint
/// at its step on the way; with a checkpoint to resume, the Simulation is
/// restored from it. Throws std::invalid_argument for a configuration a
/// Simulation does not run (stock world, shuffle seed; with a record path
/// also balancing, SyncTest, heal; with a checkpoint to write or resume also
/// balancing, SyncTest, heal, a record path, a checkpoint step or --steps
/// outside the run),
/// replay::ReplayError when the file cannot be written, and
/// SceneError
/// naming the input file, the entry and what is wrong for an input the
/// Simulation refuses (unknown id, id in use, bad body, ...).
RunResult run_with_inputs(const Scene& scene, const RunConfig& config);

}  // namespace soda
