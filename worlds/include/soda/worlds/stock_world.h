// The baseline: one plain btDiscreteDynamicsWorld with Bullet's stock
// configuration (default collision configuration, dbvt broadphase, sequential
// impulse solver), on a scene. Every speed figure SODA prints is a ratio
// against this world, measured in the same process.
//
// The scene's joints are added as Bullet's constraints, in joint id order,
// bodies of a joint not colliding unless the joint says so.
//
// It is *not* order-independent: inserting the same bodies in another order
// gives another result (docs/determinism.md). The canonical world fixes that.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {

class StockWorld {
 public:
  /// Builds the world; bodies are inserted in `insertion_order` (indices into
  /// scene.bodies), or in scene order when empty.
  explicit StockWorld(const Scene& scene, const std::vector<std::size_t>& insertion_order = {});
  ~StockWorld();
  StockWorld(const StockWorld&) = delete;
  StockWorld& operator=(const StockWorld&) = delete;

  /// One fixed step of scene.settings.dt (substeps as configured).
  void step();
  std::int64_t steps_done() const { return steps_done_; }

  std::vector<BodyState> body_states() const;
  std::uint64_t state_hash() const;
  std::size_t body_count() const;
  std::size_t sleeping_count() const;

  btDiscreteDynamicsWorld& bullet() { return *world_; }

 private:
  SceneSettings settings_;
  std::unique_ptr<btDefaultCollisionConfiguration> config_;
  std::unique_ptr<btCollisionDispatcher> dispatcher_;
  std::unique_ptr<btBroadphaseInterface> broadphase_;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver_;
  std::unique_ptr<btDiscreteDynamicsWorld> world_;
  BulletBodies bodies_;
  std::vector<std::unique_ptr<btTypedConstraint>> joints_;  // the scene's joints, added in joint id order
  std::unique_ptr<btOverlapFilterCallback> filter_;  // the pair cache's: SODA's collision filter
  std::int64_t steps_done_ = 0;
};

}  // namespace soda
