// TerritoryWorld, idle territories (docs/skip.md, "Idle territories").
//
// Why a skipped step is exact: a world whose owned bodies are all settled
// (settled.h) and that holds no ghost, sent none and keeps no contact state
// held elsewhere runs a step with no neighbour's ghost arriving as follows:
// predict rewrites the bits each settled body holds (no gravity when
// inactive, damping of +0 velocities, the same predicted transform, hit
// fraction 1) and finds the same halos, so no ghost leaves; collide runs no
// narrowphase (every pair has two inactive bodies: settled ones and statics,
// which Bullet keeps ISLAND_SLEEPING), so every manifold keeps its points;
// build_islands finds only sleeping islands (nothing solved: their bodies
// stay asleep); integrate moves no inactive body, updateDeactivation leaves
// sleeping bodies alone and the velocities they get are the +0 they hold;
// forces are cleared to the +0 they hold; no origin moved, so nothing
// migrates. What differs is not state: the broadphase's internal tree and
// its pairs without points (docs/determinism.md).
#include "settled.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {
bool TerritoryWorld::idle_ready() const {
  if (gDisableDeactivation || halos_unknown_ || parts_->replay.armed() || !ghosts_.empty() || !ghost_senders_.empty() || !outgoing_.empty() ||
      !kept_.empty() || !parts_->speculative.empty())
    return false;
  // A kinematic body that moves (or stops) in this step changes state in
  // every world: no world skips it.
  for (const Entry* e : statics_)
    if (e->description.kinematic &&
        write_kinematic_state(*e->body, e->description, settings_, steps_done_ + 1, false))
      return false;
  if (quiet_ < 0) {
    const btScalar h = btScalar(settings_.dt / settings_.substeps);
    quiet_ = 1;
    for (const Entry* e : owned_) {
      const btRigidBody& b = *e->body;
      if (!body_settled(b, h) || !zero_bits(b.getTotalForce()) || !zero_bits(b.getTotalTorque()) ||
          b.getHitFraction() != btScalar(1)) {
        quiet_ = 0;
        break;
      }
    }
  }
  return quiet_ == 1;
}

void TerritoryWorld::begin_idle_step() {
  counters_ = TerritoryCounters{};
  counters_.owned_bodies = owned_.size() + parked_.size();
  counters_.parked_bodies = parked_.size();
  local_islands_.clear();
}

}  // namespace soda
