// Internal: parking of sleeping islands outside a world's Bullet world
// (docs/skip.md): the canonical world's (canonical_world.cpp) and a territory
// world's (territory_parking.cpp). A parked island costs nothing per step but
// one query: its bodies are out of the broadphase, the body lists and the
// dispatcher; its contact state is kept as values; the btRigidBody objects
// stay alive (the world's entries own them), so every field of a parked body
// keeps its bits.
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
//     (every manifold's contact breaking threshold is at most
//     sqrt(2) * gContactBreakingThreshold: contact_threshold.h). **Wake rule**: in
//     every step, after the AABBs are updated and before the broadphase
//     pass, every island holding a body whose AABB (as updateSingleAabb
//     computes it: bullet_aabb) overlaps (closed boxes) the broadphase AABB
//     of an active body in the world goes back into the world, bodies first
//     (their AABBs as that step computes them), its manifolds after the pair
//     pass, before narrowphase. The step then runs exactly as if the island
//     had never left; an island that stays settled is parked again at the
//     step's end;
//  3. islands are the world's own (from contact manifolds, solved and put to
//     sleep per island), never broadphase pairs; which manifolds without
//     points or pairs exist is not state (docs/determinism.md).
// Parking needs Bullet's sleeping on: with gDisableDeactivation every
// sleeper wakes at the next step, so nothing is parked and every parked
// island comes back.
//
// A Parking holds the parked islands; its world decides which islands to
// park (add_island, add_contact, finish_parking) and which active bodies to
// test (touch, wake_touched), and takes bodies back through its ParkingHost.
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

/// What a world does for its Parking.
class ParkingHost {
 public:
  /// Puts a parked dynamic body back into the Bullet world with its
  /// canonical proxy (add_body_with_canonical_proxy) and collision filter
  /// (its proxy's group and mask when it was parked) and into the world's
  /// own lists.
  virtual void return_body(btRigidBody* body, int group, int mask) = 0;
  /// Drops every body whose broadphase proxy was destroyed (handle null)
  /// from the Bullet world's lists and the world's own, in one pass each.
  virtual void forget_detached_bodies() = 0;

 protected:
  ~ParkingHost() = default;
};

/// A btDiscreteDynamicsWorld that can drop many bodies at once: removing
/// them one by one is linear each (its arrays are searched), quadratic for a
/// world that parks most of its bodies.
class DetachableWorld : public btDiscreteDynamicsWorld {
 public:
  using btDiscreteDynamicsWorld::btDiscreteDynamicsWorld;
  /// Drops every collision object whose broadphase proxy was destroyed
  /// (handle null) from the world's object and rigid-body arrays, keeping
  /// the others' order.
  void compact_detached_bodies();
};

class Parking {
 public:
  Parking(ParkingHost& host, btDiscreteDynamicsWorld& world, btDbvtBroadphase& broadphase,
          btCollisionDispatcher& dispatcher);
  ~Parking();
  Parking(const Parking&) = delete;
  Parking& operator=(const Parking&) = delete;

  // --- parking, at a step's end (the host checked every body settled,
  // settled.h) ------------------------------------------------------------
  /// A parked island of these bodies (in the world now; they leave it at
  /// finish_parking). Returns its slot (an index, reused once it is woken).
  std::size_t add_island(btCollisionObject* const* bodies, int n);
  /// A manifold with points of the island in `slot` (between two of its
  /// bodies, or one of them and a static body): kept as a value.
  void add_contact(std::size_t slot, const btPersistentManifold& manifold);
  /// Takes the bodies of the islands added since the last call out of the
  /// Bullet world (their pairs, proxies and places in its lists).
  void finish_parking();

  // --- the wake rule, between the AABB update and the pair pass ----------
  /// Collects every parked island with a body whose AABB overlaps [lo, hi].
  void touch(const btVector3& lo, const btVector3& hi);
  /// Collects every parked island (sleeping switched off).
  void touch_all();
  /// Puts the bodies of the islands collected back into the world
  /// (ParkingHost::return_body), each with the AABB updateSingleAabb gives.
  void wake_touched();
  /// After the pair pass: the woken islands' manifolds, written into their
  /// pairs (created where the pass did not).
  void restore_woken_contacts();

  /// At a step boundary: puts one island back, bodies and contacts (an
  /// input for one of its bodies).
  void unpark_island(std::size_t slot);
  /// At a step boundary: puts every parked island back (parking switched
  /// off): a broadphase pass, as a snapshot restore does, then the manifolds.
  void unpark_all();

  /// Appends the manifolds of every parked island (unsorted).
  void append_contacts(std::vector<ManifoldState>& out) const;
  std::size_t parked_bodies() const { return parked_bodies_; }
  std::size_t parked_islands() const { return parked_islands_; }

 private:
  struct Island {
    std::vector<btRigidBody*> bodies;
    std::vector<std::pair<int, int>> filters;  // per body: its proxy's collision group and mask
    std::vector<ManifoldState> manifolds;
    // Per manifold: its two bodies (statics are never removed from the world).
    std::vector<std::pair<btCollisionObject*, btCollisionObject*>> pair_objects;
    std::vector<btDbvtNode*> leaves;  // one per body in tree_
    bool parked = false;
  };
  void unpark_bodies(std::size_t slot);

  ParkingHost& host_;
  btDiscreteDynamicsWorld& world_;
  btDbvtBroadphase& broadphase_;
  btCollisionDispatcher& dispatcher_;
  btDbvt tree_;                     // parked bodies' AABBs; leaf data: island index
  std::vector<Island> islands_;     // parked or free slots
  std::vector<std::size_t> free_;   // free slots of islands_
  std::vector<std::size_t> woken_;  // islands whose bodies are back, manifolds pending
  std::size_t parked_bodies_ = 0, parked_islands_ = 0;
  // Scratch.
  std::vector<std::size_t> hits_;  // touched islands (repeats allowed)
  std::vector<btRigidBody*> leaving_;
};

/// The canonical world's parking passes (canonical_world.cpp).
/// After a whole step (every substep of length h): parks every settled
/// island of the last island stage. O(bodies and manifolds in the world).
void park_settled_islands(Parking& parking, CanonicalDynamicsWorld& world, btCollisionDispatcher& dispatcher,
                          btScalar h);
/// Before the first step of a world without contact points (a scene just
/// built): parks every body that is settled (Body::asleep bodies whose
/// interpolation transform is already the prediction's), each its own
/// island; nothing if any manifold holds points.
void park_lone_settled_bodies(Parking& parking, CanonicalDynamicsWorld& world, btCollisionDispatcher& dispatcher,
                              btScalar h);

}  // namespace soda
