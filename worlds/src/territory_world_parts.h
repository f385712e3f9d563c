// Internal: what a TerritoryWorld is made of. Stages live in
// territory_world.cpp (construction, predict, exchange_ghosts, readout),
// territory_collide.cpp (collide: holder rule, seeding), territory_islands.cpp
// (build_islands, border fragments, solve) and territory_migrate.cpp
// (integrate, migrate).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "contact_threshold.h"
#include "pair_cache.h"
#include "parking.h"
#include "coloured_solver.h"
#include "soda/worlds/territory_world.h"
#include "world_teardown.h"

namespace soda {

enum class Role { Owned, Ghost, Static };

struct TerritoryWorld::Entry {
  Body description;
  std::unique_ptr<btCollisionShape> shape;
  std::unique_ptr<btRigidBody> body;
  Role role = Role::Owned;
  WorldId owner = kNoWorld;        // this world for owned bodies, the sender for ghosts
  std::vector<WorldId> sent_to;    // worlds that got this body as a ghost this step, ascending
  bool refreshed = false;          // ghost: a record arrived this step
  int node = -1;                   // island node this step (-1: static)
  std::int64_t seed_step = -1;     // step at which seeds_ held a pair with this body
  btVector3 halo_min, halo_max;    // owned: the halo computed by predict
  std::int64_t halo_owned_step = -1;  // owned: step at which predict found every cell of the halo owned here
  // Owned: border culling (docs/skip.md). A box in metres, the 27 cells
  // around an interior cell shrunk by a rounding guard, that the halo lay in
  // when predict last looked its cells up: a halo still inside it has every
  // cell owned here, so it is not looked up again. Empty until then.
  Vec3 safe_lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 safe_hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  bool clean = false;              // owned, in a replayed step: state and contacts at its start as the old run's
  bool parked = false;             // owned, parked outside the Bullet world (TerritoryWorld::set_parking)
  std::size_t parked_slot = 0;     // parked: its island's slot in Parts::parking
  std::size_t parked_index = 0;    // parked: its index in TerritoryWorld::parked_

  BodyId id() const { return description.id; }
};

/// The dispatcher runs the near callback of the world it belongs to; its
/// manifolds break at manifold_breaking_threshold (contact_threshold.h).
class TerritoryWorld::Dispatcher final : public CappedDispatcher {
 public:
  Dispatcher(btCollisionConfiguration* config, TerritoryWorld* world)
      : CappedDispatcher(config), world_(world) {
    setNearCallback(&Dispatcher::near);
  }

 private:
  static void near(btBroadphasePair& pair, btCollisionDispatcher& dispatcher, const btDispatcherInfo&) {
    static_cast<Dispatcher&>(dispatcher).world_->near_callback(&pair);
  }
  TerritoryWorld* world_;
};

/// What a territory world does for its Parking (parking.h).
struct TerritoryWorld::ParkingLink final : ParkingHost {
  explicit ParkingLink(TerritoryWorld* w) : world(w) {}
  void return_body(btRigidBody* body) override { world->return_parked(body); }
  void forget_detached_bodies() override { world->forget_parked(); }
  TerritoryWorld* world;
};

/// Every Bullet object of one territory world is its own (pool allocators
/// are not thread-safe), except that a world rebuilt from a snapshot may
/// share the collision configuration (its pools) of the world it replaces.
/// Destroyed before the bodies it holds (~btCollisionWorld reads them),
/// pairs first so that teardown is linear in bodies (world_teardown.h).
struct TerritoryWorld::Parts {
  Parts(TerritoryWorld* owner, std::shared_ptr<btDefaultCollisionConfiguration> shared)
      : config(shared ? std::move(shared) : std::make_shared<btDefaultCollisionConfiguration>()),
        dispatcher(config.get(), owner),
        parking_link(owner) {}
  ~Parts() { release_all_pairs(broadphase, dispatcher); }
  Parts(const Parts&) = delete;
  Parts& operator=(const Parts&) = delete;
  std::shared_ptr<btDefaultCollisionConfiguration> config;  // first: outlives every user of its pools
  Dispatcher dispatcher;
  PairCache pairs;  // before the broadphase, which uses it (pair_cache.h)
  btDbvtBroadphase broadphase{&pairs};
  ColouredSolver solver;  // docs/coloured-solve.md
  DetachableWorld world{&dispatcher, &broadphase, &solver, config.get()};
  ParkingLink parking_link;
  Parking parking{parking_link, world, broadphase, dispatcher};  // idle unless TerritoryWorld::set_parking(true)
  btManifoldArray scratch;  // near callback
  std::vector<btPersistentManifold*> speculative;  // held manifolds given a speculative point this step
  // solve_border_island's copies of a merged island's manifolds, reused from
  // step to step (each is reset to a fresh manifold's state before use).
  std::vector<std::unique_ptr<btPersistentManifold>> manifold_copies;
  btContactSolverInfo island_info;  // an island's own settings (island_solver_settings.h)
};

/// A component of this world's contact graph that waits for glue (it holds
/// a ghost or a body sent as a ghost); its nodes and manifolds are ranges of
/// the CSR arrays (territory_islands.cpp).
struct TerritoryWorld::Component {
  int index = 0;                   // component number
  BodyId root = 0;                 // smallest id
  bool has_ghost = false;
  std::vector<LinkIn> links_in;
};

/// A body rebuilt from a BodyRecord for a border island solve.
struct TerritoryWorld::Copy {
  std::unique_ptr<btCollisionShape> shape;
  std::unique_ptr<btRigidBody> body;
};

inline TerritoryWorld::Entry& entry_of(const btCollisionObject* object) {
  return *static_cast<TerritoryWorld::Entry*>(object->getUserPointer());
}

/// The PartitionError text for a body that reached a world outside this
/// world's neighbourhood (predict: its halo overlaps `cell` of `other`;
/// migrate: its new home `cell` belongs to `other`): names the body, its
/// speed and the remedy, a larger reach speed.
std::string beyond_reach(WorldId world, std::int64_t step, BodyId body, double speed, const char* what,
                         const CellCoord& cell, WorldId other, const TerritoryMap& map);

}  // namespace soda
