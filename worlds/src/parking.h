// Internal: parking of sleeping islands outside a canonical world's Bullet
// world (#18, docs/skip.md). A parked island costs nothing per step but one
// query: its bodies are out of the broadphase, the body lists and the
// dispatcher; its contact state is kept as values; the btRigidBody objects
// stay alive (CanonicalWorld::Entry owns them), so every field of a parked
// body keeps its bits.
//
// Why it is exact (the state hash of a run is the same with parking on and
// off, for every step):
//  1. only *settled* islands are parked: every body ISLAND_SLEEPING with a
//     sleep timer > 0 and zero velocities, and its interpolation transform
//     equal, bit for bit, to what the next step's predictUnconstraintMotion
//     would write (btTransformUtil::integrateTransform of its transform at
//     zero velocity). A settled island left in the world does nothing in a
//     step: no gravity, no solve, no integration (inactive), damping and
//     prediction rewrite the same bits, updateActivationState zeroes zero
//     velocities, and no narrowphase runs between two inactive bodies (its
//     manifolds with statics and with each other keep their points). So its
//     state at every later step boundary is its state when parked;
//  2. it can only change through a contact point with an awake body, and a
//     point can only appear while the two bodies' Bullet AABBs overlap
//     (every shape's contact breaking threshold at most
//     sqrt(2) * gContactBreakingThreshold, the territory worlds' contract;
//     an island with a body beyond it is never parked). **Wake rule**: in
//     every step, after predictUnconstraintMotion and updateAabbs and before
//     the broadphase pass, every island holding a body whose AABB (as
//     updateSingleAabb computes it: bullet_aabb) overlaps (closed boxes) the
//     broadphase AABB of an active body in the world goes back into the
//     world, bodies first (their AABBs as that step computes them), its
//     manifolds after the pair pass, before narrowphase. The step then runs
//     exactly as if the island had never left; an island that stays settled
//     is parked again at the step's end;
//  3. islands are the canonical world's (from contact manifolds, solved and
//     put to sleep per island), never broadphase pairs; which manifolds
//     without points or pairs exist is not state (docs/determinism.md).
// Parking needs Bullet's sleeping on: with gDisableDeactivation every
// sleeper wakes at the next step, so nothing is parked and every parked
// island comes back.
//
// Thread safety: none; one world's thread uses it.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include <BulletCollision/BroadphaseCollision/btDbvt.h>
#include <btBulletDynamicsCommon.h>

#include "soda/worlds/world_snapshot.h"

namespace soda {

class CanonicalDynamicsWorld;

class Parking {
 public:
  Parking(CanonicalDynamicsWorld& world, btDbvtBroadphase& broadphase, btCollisionDispatcher& dispatcher);
  ~Parking();
  Parking(const Parking&) = delete;
  Parking& operator=(const Parking&) = delete;

  /// After a whole step (every substep of length h): parks every settled
  /// island of the last island stage. O(bodies and manifolds in the world).
  void park_settled(btScalar h);
  /// Before the first step of a world without contact points (a scene
  /// just built): parks every body that is settled (Body::asleep bodies
  /// whose interpolation transform is already the prediction's), each its
  /// own island; nothing if any manifold holds points.
  void park_lone_settled(btScalar h);
  /// The wake rule's first half (CanonicalDynamicsWorld::computeOverlappingPairs,
  /// before Bullet's pair pass): puts back the bodies of every island an
  /// active body's AABB touches (every island with sleeping off).
  void wake_touched();
  /// Its second half (after the pair pass): the woken islands' manifolds.
  void restore_woken_contacts();
  /// Puts every parked island back (bodies and manifolds) at a step
  /// boundary: parking switched off.
  void unpark_all();

  /// Appends the manifolds of every parked island (unsorted).
  void append_contacts(std::vector<ManifoldState>& out) const;
  std::size_t parked_bodies() const { return parked_bodies_; }
  std::size_t parked_islands() const { return parked_islands_; }

 private:
  struct Island {
    std::vector<btRigidBody*> bodies;
    std::vector<ManifoldState> manifolds;
    // Per manifold: its two bodies (statics are never removed from the world).
    std::vector<std::pair<btCollisionObject*, btCollisionObject*>> pair_objects;
    std::vector<btDbvtNode*> leaves;  // one per body in tree_
    bool parked = false;
  };
  void unpark_bodies(std::size_t island);
  /// A parked island of these bodies (leaves in tree_, bodies to leaving_); its slot.
  std::size_t add_island(btCollisionObject* const* bodies, int n);
  /// Takes leaving_'s bodies out of Bullet's world.
  void remove_leaving();

  CanonicalDynamicsWorld& world_;
  btDbvtBroadphase& broadphase_;
  btCollisionDispatcher& dispatcher_;
  btDbvt tree_;                     // parked bodies' AABBs; leaf data: island index
  std::vector<Island> islands_;     // parked or free slots
  std::vector<std::size_t> free_;   // free slots of islands_
  std::vector<std::size_t> woken_;  // islands whose bodies are back, manifolds pending
  std::size_t parked_bodies_ = 0, parked_islands_ = 0;
  // Scratch.
  std::vector<int> island_state_;   // per island of the last stage: 1 = park
  std::vector<btRigidBody*> leaving_;
};

}  // namespace soda
