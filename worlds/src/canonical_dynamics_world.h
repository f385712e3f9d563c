// Internal: the btDiscreteDynamicsWorld subclass behind CanonicalWorld. It
// replaces two stages of Bullet's internalSingleStepSimulation:
//
//   predictUnconstraintMotion        (stock: per body, order-free) *
//   performDiscreteCollisionDetection
//     updateAabbs                    (stock: per body) *
//     computeOverlappingPairs        OVERRIDDEN: + full stale-pair sweep
//     dispatchAllCollisionPairs      (stock: per pair; body0 = lower id) *
//     + speculative contacts         ADDED: per pair with a fast body (docs/ccd.md)
//   calculateSimulationIslands       OVERRIDDEN: no-op (Bullet's unites broadphase pairs)
//   solveConstraints                 OVERRIDDEN: IslandStage (below)
//   integrateTransforms              (stock: per body; CCD off), after
//                                    the speculative points are removed *
//
// * with a solver pool and above a size, Bullet's loop over bodies or pairs
//   runs on the pool's threads, same bits (parallel_stages.h,
//   canonical_stages.cpp).
//   updateActivationState            (stock: per body timers)
//
// IslandStage, every step:
//  1. union-find over dynamic bodies (id order) joined by manifolds that hold
//     contact points (and whose bodies both merge islands) and by joints
//     that have not broken: IslandBuilder, shared with the territory world
//     (island_builder.h);
//  2. islands numbered by their smallest body id, bodies in id order;
//  3. sleeping per island, as btSimulationIslandManager::buildIslands: all
//     bodies want sleep -> ISLAND_SLEEPING; else sleepers are woken;
//  4. each awake island's manifolds sorted by (id0, id1), its joints by
//     joint id, and solved alone
//     (one solveGroup call per island; batch size 1, so Bullet's early exit
//     and iteration overrides are per island). Awake lone bodies without
//     contacts are solved in one call: they have no solver rows, so each one's
//     result is its own integration, whatever else is in the call. Large
//     islands are solved coloured by the ColouredSolver (coloured_solver.h),
//     except islands with joints: Bullet's own serial loop solves those
//     (joint rows first, in joint id order, then the contacts).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "coloured_solver.h"
#include "island_builder.h"
#include "parking.h"
#include "soda/worlds/canonical_world.h"

namespace soda {


/// Adds a body whose user index is its global id to a world over a dbvt
/// broadphase: its proxy gets unique id = global id + 1, so every pair's body0
/// is its lower id (shared with the territory world).
/// The proxy carries the body's collision filter, group and mask
/// (collision_filter.h: the world's pair cache asks BodyFilter).
void add_body_with_canonical_proxy(btDiscreteDynamicsWorld& world, btDbvtBroadphase& broadphase,
                                   btRigidBody* body, int group, int mask);

/// After a proxy's insertion into `broadphase`'s tree of moving proxies:
/// the tree rebuilt top down when its leaf count reaches a power of two
/// from 4,096 on (add_body_with_canonical_proxy calls it).
void rebalance_after_insertion(btDbvtBroadphase& broadphase);

/// Removes every pair whose dbvt leaf volumes no longer overlap (stock Bullet
/// removes a fraction per step), so that the pair set is a function of the
/// leaf volumes alone. Returns the number of pairs left.
std::size_t remove_stale_pairs(btDbvtBroadphase& broadphase, btDispatcher* dispatcher);

/// The sleeping decision for one island, as
/// btSimulationIslandManager::buildIslands: if no body is ACTIVE_TAG or
/// DISABLE_DEACTIVATION every body becomes ISLAND_SLEEPING, else sleepers
/// become WANTS_DEACTIVATION with timer 0. Returns true if the island is
/// awake afterwards (it must be solved).
bool decide_island_sleeping(btCollisionObject* const* bodies, int count);

/// After decide_island_sleeping, as the manifold loop of Bullet's
/// btSimulationIslandManager::buildIslands: a kinematic body that is not
/// ISLAND_SLEEPING (it moves this step: docs/scene-format.md, "Kinematic
/// bodies") activates the other body of each manifold with points it is in.
/// Returns whether the island is awake now (any body active).
bool wake_touched_by_kinematic(bool awake, btCollisionObject* const* bodies, int count,
                               btPersistentManifold* const* manifolds, int manifold_count);

/// The step of that rule for one pair: activates the body a moving
/// kinematic body touches. Returns whether it did.
bool kinematic_wakes(btCollisionObject* a, btCollisionObject* b);

class CanonicalDynamicsWorld final : public DetachableWorld, public ParkingHost {
 public:
  CanonicalDynamicsWorld(btDispatcher* dispatcher, btDbvtBroadphase* broadphase,
                         ColouredSolver* solver, btCollisionConfiguration* config);

  /// Inserts a body whose user index is its global id: its broadphase proxy
  /// gets unique id = global id + 1, so every pair's body0 is its lower id,
  /// and the collision filter `group`, `mask` (collision_filter.h).
  void add_body(btRigidBody* body, int group, int mask);

  const StepStats& stats() const { return stats_; }

  /// Adds a joint's constraint (joint_factory.h) between bodies already in
  /// the world; with collide_connected false its bodies do not collide with
  /// each other while it holds (Bullet's constraint refs; a broken joint no
  /// longer filters). Joints are solved in joint id order, whatever the
  /// order they were added in.
  void add_joint(btTypedConstraint* constraint, bool collide_connected);
  /// Whether a body has a joint (a jointed island never parks).
  bool jointed(const btCollisionObject* body) const {
    return !jointed_.empty() && jointed_.count(body) != 0;
  }

  /// SolverDefaults::Bullet (canonical_world.h): no speculative contacts,
  /// every island solved with the world's solver info as it is.
  void set_bullet_defaults(bool on) { bullet_defaults_ = on; }

  // --- for Parking (parking.h) ------------------------------------------
  /// Parking's wake rule runs inside computeOverlappingPairs (null: none).
  void set_parking(Parking* parking) { parking_ = parking; }
  /// Islands of the last island stage: count, and island k's bodies (by id).
  int island_count() const { return islands_.island_count(); }
  int island_size(int k) const { return islands_.size(k); }
  btCollisionObject* const* island_bodies(int k) const { return island_bodies_.data() + islands_.begin(k); }
  /// The dynamic bodies in the world.
  const std::vector<btRigidBody*>& dynamic_bodies() const { return dynamic_bodies_; }
  /// ParkingHost: a parked body back (add_body).
  void return_body(btRigidBody* body, int group, int mask) override { add_body(body, group, mask); }
  /// ParkingHost: drops every body whose broadphase proxy was destroyed
  /// (handle null) from the world's lists, in one pass over each.
  void forget_detached_bodies() override;

  void computeOverlappingPairs() override;
  /// Bullet's discrete collision detection, then a speculative contact for
  /// every pair with a fast body and no point (speculative_contact.h).
  void performDiscreteCollisionDetection() override;
  /// Removes the step's speculative points, then integrates as Bullet does.
  void integrateTransforms(btScalar time_step) override;
  void calculateSimulationIslands() override {}
  /// As Bullet's, per body on the solver pool's threads (parallel_stages.h).
  void predictUnconstraintMotion(btScalar time_step) override;
  // Kinematic bodies are moved by their owner (write_kinematic_state) before
  // the step, velocities included: Bullet's pass, which would derive them
  // from the interpolation transform, must not run.
  void saveKinematicState(btScalar) override {}
  /// As Bullet's: AABBs computed on the pool's threads, the broadphase
  /// updated on the stepping thread in object order.
  void updateAabbs() override;
  void solveConstraints(btContactSolverInfo& solver_info) override;

 private:
  void sort_dynamic_bodies();
  void build_islands();
  void decide_sleeping();
  void collect_island_manifolds();
  void solve_islands(btContactSolverInfo& solver_info);
  std::size_t coloured_so_far() const;
  // canonical_stages.cpp: Bullet's per-item loops on the pool.
  SolverPool* stage_pool() const;  // null: no pool, or a pool of one thread
  void note_stage_threads(int threads);
  void dispatch_pairs();
  void integrate_bodies(btScalar time_step);

  btDbvtBroadphase* broadphase_;
  ColouredSolver* solver_;
  Parking* parking_ = nullptr;
  StepStats stats_;
  bool bodies_sorted_ = true;
  bool bullet_defaults_ = false;
  std::vector<btRigidBody*> dynamic_bodies_;  // sorted by id; user index 2 = position
  std::vector<btRigidBody*> kinematic_bodies_;  // any order: they wake parked islands they touch while they move
  std::size_t sorted_count_ = 0;  // while !bodies_sorted_: its first ones, sorted by id

  // Per-step scratch, kept to avoid reallocation.
  IslandBuilder islands_;  // nodes: dynamic_bodies_ positions (id order)
  std::vector<btPersistentManifold*> contact_manifolds_;
  std::vector<btCollisionObject*> island_bodies_;         // by island, then id (islands_.begin)
  IslandItems<btPersistentManifold*> island_manifolds_;  // awake islands' manifolds, by island, then (id0, id1)
  IslandItems<btTypedConstraint*, JointId> island_joints_;  // joints that hold, by island, then joint id
  std::unordered_map<const btCollisionObject*, int> jointed_;  // bodies with joints: how many
  // solve_islands: the awake islands of a step, and solvers for the small
  // ones solved side by side on the pool (one per pool thread, taken by a
  // task for its islands and given back).
  struct IslandJob {
    int body_begin, body_count;
    std::size_t manifold_begin;
    int manifold_count;
    int joint_begin, joint_count;
  };
  std::vector<IslandJob> big_islands_, small_islands_;
  std::vector<std::unique_ptr<ColouredSolver>> spare_solvers_;
  std::unique_ptr<std::atomic<bool>[]> spare_taken_;
  std::vector<btCollisionObject*> lone_bodies_;
  std::vector<btPersistentManifold*> speculative_;  // manifolds given a speculative point this step
  struct Aabb {
    btVector3 min, max;
  };
  std::vector<Aabb> aabbs_;      // per collision object (updateAabbs)
  std::vector<int> box_pairs_;   // box-box pairs of the step, by pair index (dispatch_pairs)
  btContactSolverInfo island_info_;  // an island's own settings (island_solver_settings.h)
};

}  // namespace soda
