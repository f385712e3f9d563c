// Internal: the island replay a territory world runs in a step it was told
// to replay (TerritoryWorld::set_replay, soda/worlds/step_replay.h). Three
// verbs, in the order of the step:
//
//   mark_clean   before anything moves (predict): which owned bodies are
//                clean — raw state, mass, friction and restitution, every
//                contact and every joint they are in, at the step's start,
//                equal to the old run's bit for bit, under the same gravity
//   take         for each island about to be solved in place: if every body
//                is clean and the old run solved an island of exactly these
//                bodies, queue its bodies' and manifolds' old results
//   finish       at the end of integrate (mid-step replays: right after the
//                solve): the queued bodies and manifolds take the old
//                results (verify: the ones just solved must equal them)
//
// Invariants:
//  1. an island is replayed only if all its bodies are clean and the old
//     run's islands hold one of exactly these bodies (by smallest id, then
//     every id), and `after` holds every one of its bodies: then its result
//     is the old run's (DESIGN.md §2), and every other island is solved;
//  2. a manifold of a replayed island absent from `after` was empty at the
//     old run's end (a refresh between substeps, a speculative point
//     cleared): finish() empties it;
//  3. verify never writes: a replayed island is solved as usual and compared,
//     a difference is a std::logic_error naming the world, the step and the
//     body or pair.
//
// Thread safety: none; one per world, used by its stepping thread.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "island_builder.h"
#include "soda/grid/territory_map.h"
#include "soda/worlds/step_replay.h"

namespace soda {

class IslandReplay {
 public:
  /// Arms the replay for the next step (throws std::invalid_argument unless
  /// before, after and islands are all given).
  void set(const StepReplay& replay);
  /// The step is over: nothing armed.
  void clear() { replay_ = StepReplay{}; }
  bool armed() const { return replay_.before != nullptr; }
  bool mid_step() const { return replay_.mid_step; }
  bool verify() const { return replay_.verify; }
  /// True while replayed bodies wait for finish().
  bool pending() const { return !bodies_.empty(); }

  /// The owned bodies at the step's start, ascending id, their descriptions
  /// (same order), every contact state of the world now (held and kept, by
  /// (id0, id1)) and the world's gravity now: an input may have changed a
  /// body's material or the gravity at this boundary, which its raw state
  /// does not show.
  /// `joints`: those held here now, by id; one held in one run only, or
  /// whose description or broken flag differs from the old run's (an input
  /// removed it or set its motor), makes its bodies dirty.
  void mark_clean(const std::vector<btRigidBody*>& owned, const std::vector<const Body*>& descriptions,
                  const std::vector<ManifoldState>& contacts, const std::vector<JointSnapshot>& joints,
                  const Vec3& gravity);
  /// An island about to be solved in place: its bodies (ascending id) and
  /// the manifolds it holds (`held`'s island `island`, by key). True if it
  /// is replayed (invariant 1): queued for finish().
  bool take(btCollisionObject* const* bodies, int body_count, const IslandItems<btPersistentManifold*>& held,
            int island);
  /// Writes (or verifies) every queued island; `world`, `step` for messages.
  void finish(WorldId world, std::int64_t step);

 private:
  bool clean(BodyId id) const;
  void mark_joints_dirty(const std::vector<JointSnapshot>& joints);

  StepReplay replay_;
  std::vector<std::pair<BodyId, std::uint32_t>> index_;  // the old run's islands by smallest id
  std::vector<std::pair<BodyId, bool>> clean_;           // owned bodies by id: clean?
  std::vector<std::pair<btCollisionObject*, const BodyDynamicState*>> bodies_;
  std::vector<std::pair<btPersistentManifold*, const ManifoldState*>> manifolds_;
};

}  // namespace soda
