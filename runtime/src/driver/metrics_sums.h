// Internal: a world's metrics added up over its steps and over the
// processes of its run (world_metrics.h; world_metrics.cpp).
#pragma once

#include "soda/runtime/world_metrics.h"

namespace soda {

/// Adds what a world counted in one step (TerritoryCounters) to its metrics
/// by each counter's fold.
void add_step_counters(WorldMetrics& m, const TerritoryCounters& step);

/// Adds to `m` what another part of the same world's run counted (a
/// process a restore replaced, heal and SyncTest): Sum added, Max the
/// larger, Now kept; the stages and traffic added, cpu_step_max_ms the
/// larger. The per-step series and means are the caller's.
void add_replaced_run(WorldMetrics& m, const WorldMetrics& replaced);

}  // namespace soda
