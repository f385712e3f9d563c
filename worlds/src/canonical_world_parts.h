// Internal: what one CanonicalWorld owns, in construction order.
#pragma once

#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "collision_filter.h"
#include "pair_cache.h"
#include "coloured_solver.h"
#include "parking.h"
#include "soda/worlds/canonical_world.h"
#include "contact_threshold.h"
#include "world_teardown.h"

namespace soda {

/// Every Bullet object a world uses is its own: pool allocators of a
/// collision configuration and dispatcher are not thread-safe. Destroyed
/// before the bodies it holds (~btCollisionWorld reads them), pairs first
/// so that teardown is linear in bodies (world_teardown.h).
struct CanonicalWorldParts {
  CanonicalWorldParts() { pairs.setOverlapFilterCallback(&filter); }
  ~CanonicalWorldParts() { release_all_pairs(broadphase, dispatcher); }
  CanonicalWorldParts(const CanonicalWorldParts&) = delete;
  CanonicalWorldParts& operator=(const CanonicalWorldParts&) = delete;

  btDefaultCollisionConfiguration config;
  CappedDispatcher dispatcher{&config};  // contact_threshold.h
  BodyFilter filter;  // the pair cache's (collision_filter.h)
  PairCache pairs;  // before the broadphase, which uses it (pair_cache.h)
  btDbvtBroadphase broadphase{&pairs};
  ColouredSolver solver;  // docs/coloured-solve.md
  CanonicalDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  Parking parking{world, world, broadphase, dispatcher};  // idle unless CanonicalWorld::set_parking(true)
};

/// The insertion order of `count` bodies: `order` itself (it must list every
/// index below count exactly once), or 0 .. count-1 when empty. Throws
/// std::invalid_argument otherwise. canonical_world.cpp.
std::vector<std::size_t> resolve_insertion_order(const std::vector<std::size_t>& order, std::size_t count);

struct CanonicalWorld::JointEntry {
  Joint description;
  std::unique_ptr<btTypedConstraint> constraint;
};

struct CanonicalWorld::Entry {
  Body description;
  std::shared_ptr<btCollisionShape> shape;
  std::unique_ptr<btRigidBody> body;
};

}  // namespace soda
