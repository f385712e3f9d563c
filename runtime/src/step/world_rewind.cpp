// One world's process going back in time from outside (docs/rollback.md):
// a Simulation's rewind for an input at a past step, and the states it
// keeps for one.
#include <stdexcept>
#include <string>

#include "embedding/run_control.h"
#include "step/world_process.h"

namespace soda {

// Going back in time from outside (docs/rollback.md): the step begins again
// at the boundary; nothing of later steps stays.
void PartitionedWorld::Process::rewind(TerritoryWorld& world, std::int64_t scene_step) {
  ++rewinds_;
  s_.begin_again(world, scene_step * substeps_);
  s_.inbox.clear();
  s_.fragments.clear();
  s_.next_publish = scene_step + 1;  // the buffer dropped the later entries
  kept_.states().erase(kept_.states().upper_bound(s_.step), kept_.states().end());
  spec_->reset(s_.step);
  if (safety_.horizon) safety_.horizon->report(s_.world->id(), s_.step);
}

// A rewind pending for this world (RunControl::take_rewind), taken: the
// world is rebuilt from its state on this thread. A world with one pending
// starts no step (RunControl::may_start), so it is at a step boundary.
bool PartitionedWorld::Process::take_rewind() {
  if (!output_.rewind || !output_.control) return false;
  std::shared_ptr<const WorldSnapshot> state = output_.control->take_rewind(s_.world->id());
  if (!state) return false;
  if (s_.phase != StepPhase::Predict)
    throw std::logic_error("world " + std::to_string(s_.world->id()) + " has a rewind pending in the middle of step " +
                           std::to_string(s_.step));
  StageClock::Scope rollback(clock_, Stage::Rollback);
  output_.rewind(*state);
  return true;
}

const WorldSnapshot* PartitionedWorld::Process::kept_state(std::int64_t scene_step) const {
  auto it = kept_.states().find(scene_step * substeps_);
  return it == kept_.states().end() ? nullptr : &it->second;
}

}  // namespace soda
