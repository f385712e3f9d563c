// Internal: run_scene with user inputs (RunConfig::inputs): the scene on a
// Simulation, the inputs given through its input calls before it starts.
#pragma once

#include "soda/runtime/run.h"

namespace soda {

/// run_scene when config.inputs is set (validated there first). Throws
/// std::invalid_argument for a configuration a Simulation does not run
/// (stock world, watchdog heal, SyncTest, shuffle seed) and SceneError
/// naming the input file, the entry and what is wrong for an input the
/// Simulation refuses (unknown id, id in use, bad body, ...).
RunResult run_with_inputs(const Scene& scene, const RunConfig& config);

}  // namespace soda
