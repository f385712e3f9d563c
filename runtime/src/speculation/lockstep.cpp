// Lockstep (lockstep.h): the scene step boundaries of a world that never
// runs ahead.
#include "speculation/lockstep.h"

#include <algorithm>

#include "embedding/run_control.h"

namespace soda {

void Lockstep::report(WorldStepReport report) { c_.validator->report(std::move(report)); }

Verdict Lockstep::step_ended(const TerritoryCounters&) {
  const WorldStep& s = c_.step;
  if (s.step % c_.substeps != 0) return {};
  StageClock::Scope checkpoint(c_.clock, Stage::Checkpoint);
  if (c_.safety.keep_states) c_.kept.states().emplace(s.step, s.world->part_snapshot());
  if (c_.safety.horizon) c_.safety.horizon->report(s.world->id(), s.step);
  // One scene step below GVT stays too: the watchdog's heal of a
  // penetration restores the step before the one that found it.
  if (c_.safety.keep_states)
    c_.kept.states().erase(c_.kept.states().begin(),
                           c_.kept.states().lower_bound(c_.safety.horizon->gvt() - c_.substeps));
  return {};
}

// Kept states (rollback for past inputs): a step above GVT may still be
// rewritten, so only steps below it are committed.
void Lockstep::published(std::int64_t scene_step) {
  std::int64_t commit = scene_step - 1;
  if (c_.safety.keep_states) commit = std::min(commit, c_.safety.horizon->gvt() / c_.substeps - 1);
  c_.output.buffer->raise_commit_step(commit);
  c_.output.control->published(c_.step.world->id(), scene_step);
}

}  // namespace soda
