// Internal: what one CanonicalWorld owns, in construction order.
#pragma once

#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "soda/worlds/canonical_world.h"

namespace soda {

/// Every Bullet object a world uses is its own: pool allocators of a
/// collision configuration and dispatcher are not thread-safe.
struct CanonicalWorldParts {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  CanonicalDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
};

/// The insertion order of `count` bodies: `order` itself (it must list every
/// index below count exactly once), or 0 .. count-1 when empty. Throws
/// std::invalid_argument otherwise. canonical_world.cpp.
std::vector<std::size_t> resolve_insertion_order(const std::vector<std::size_t>& order, std::size_t count);

struct CanonicalWorld::Entry {
  Body description;
  std::unique_ptr<btCollisionShape> shape;
  std::unique_ptr<btRigidBody> body;
};

}  // namespace soda
