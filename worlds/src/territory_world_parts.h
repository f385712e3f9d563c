// Internal: what a TerritoryWorld is made of. Stages live in
// territory_world.cpp (construction, predict, exchange_ghosts, readout),
// territory_collide.cpp (collide: holder rule, seeding), territory_islands.cpp
// (build_islands, border fragments, solve) and territory_migrate.cpp
// (integrate, migrate); islands, the merged-island path and the island
// replay are rooms of their own (island_builder.h, border_island_solver.h,
// island_replay.h) that the world holds here.
#pragma once

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <limits>
#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "border_island_solver.h"
#include "contact_threshold.h"
#include "island_builder.h"
#include "island_replay.h"
#include "collision_filter.h"
#include "pair_cache.h"
#include "parking.h"
#include "coloured_solver.h"
#include "soda/worlds/territory_world.h"
#include "static_catalog.h"
#include "world_teardown.h"

namespace soda {

enum class Role { Owned, Ghost, Static };

struct TerritoryWorld::Entry {
  Body description;
  std::shared_ptr<btCollisionShape> shape;
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
  bool parked = false;             // owned, parked outside the Bullet world (TerritoryWorld::set_parking)
  std::size_t parked_slot = 0;     // parked: its island's slot in Parts::parking
  std::size_t parked_index = 0;    // parked: its index in TerritoryWorld::parked_
  int joints = 0;                  // owned: joints held here with this body (a jointed body never parks)

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
  void return_body(btRigidBody* body, int, int) override { world->return_parked(body); }
  void forget_detached_bodies() override { world->forget_parked(); }
  TerritoryWorld* world;
};

/// A joint held here (invariant 6): its description and its constraint
/// between the Bullet bodies of its ends (owned or static).
struct TerritoryWorld::HeldJoint {
  Joint description;
  std::unique_ptr<btTypedConstraint> constraint;
};

/// The anchors of the joint groups `joints` make (invariant 6): for every
/// dynamic body they connect, the smallest id of its group; ends for which
/// `is_static` is true join nothing.
std::unordered_map<BodyId, BodyId> joint_anchors(const std::vector<const Joint*>& joints,
                                                 const std::function<bool(BodyId)>& is_static);

/// What a territory world shows its border-island solver.
struct TerritoryWorld::BorderLink final : BorderIslandHost {
  explicit BorderLink(TerritoryWorld* w) : world(w) {}
  btCollisionObject* const* component_bodies(int component, int& count) const override;
  btPersistentManifold* const* component_manifolds(int component, int& count) const override;
  bool owns_body(const btCollisionObject* body) const override;
  btCollisionObject* static_body(BodyId id) const override;
  btRigidBody* owned_body(BodyId id) const override;
  bool keeps_pair(BodyId id0, BodyId id1) const override;
  btTypedConstraint* held_joint(JointId id) const override;
  void break_joint(JointId id) override;
  TerritoryWorld* world;
};

/// The fixed statics this world knows (static_catalog.h) and which of them
/// it holds in its Bullet world.
struct TerritoryWorld::Statics {
  explicit Statics(TerritoryWorld* w) : world(w) {}
  /// At construction: the catalog; nothing held yet.
  void init(std::shared_ptr<const StaticCatalog> c);
  /// At the start of every predict: the first time, holds the statics that
  /// overlap the world's own cells dilated by the map's reach (a world that
  /// is never stepped, another rank's, holds none).
  void prepare() {
    if (!own_cells_loaded) load_own_cells();
  }
  /// Before collide: holds every static that the halo's `cells` may meet.
  void load(const CellBox& cells) {
    const CellBox c = clamp_cells(cells, world->map_.box());
    if (!all_loaded(c)) load_slow(c);
  }
  /// Holds the static `id` from now on (a joint ends on it); nothing if `id`
  /// is not a fixed static.
  void hold(BodyId id);
  /// The static `id` for a solve on copies: held, or a detached copy (null
  /// if `id` is no static). The stepping thread only.
  btCollisionObject* object(BodyId id);
  /// True if `id` is a static body of the scene (fixed or kinematic).
  bool is_static(BodyId id) const;

  TerritoryWorld* world;
  std::shared_ptr<const StaticCatalog> catalog;
  std::vector<std::uint64_t> loaded;  // bit per box cell: every static overlapping it is held
  std::vector<char> held;             // per catalog index
  std::size_t held_count = 0;
  bool own_cells_loaded = false;
  struct Detached {
    std::shared_ptr<btCollisionShape> shape;
    std::unique_ptr<btRigidBody> body;
  };
  std::unordered_map<BodyId, Detached> detached;

 private:
  void load_own_cells();
  bool all_loaded(const CellBox& c) const;
  void load_slow(const CellBox& c);
  void hold_index(std::size_t i);
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
        parking_link(owner),
        border_link(owner),
        border(owner->id(), border_link),
        statics(owner) {
    pairs.setOverlapFilterCallback(&filter);
  }
  ~Parts() { release_all_pairs(broadphase, dispatcher); }
  Parts(const Parts&) = delete;
  Parts& operator=(const Parts&) = delete;
  std::shared_ptr<btDefaultCollisionConfiguration> config;  // first: outlives every user of its pools
  Dispatcher dispatcher;
  BodyFilter filter;  // the pair cache's (collision_filter.h)
  PairCache pairs;  // before the broadphase, which uses it (pair_cache.h)
  btDbvtBroadphase broadphase{&pairs};
  ColouredSolver solver;  // docs/coloured-solve.md
  DetachableWorld world{&dispatcher, &broadphase, &solver, config.get()};
  ParkingLink parking_link;
  Parking parking{parking_link, world, broadphase, dispatcher};  // idle unless TerritoryWorld::set_parking(true)
  btManifoldArray scratch;  // near callback
  std::vector<btPersistentManifold*> speculative;  // held manifolds given a speculative point this step
  // The step runs ahead of the commit horizon (apply_ghosts' `speculative`):
  // a neighbour's messages may come from a run it will take back.
  bool step_runs_ahead = false;
  btContactSolverInfo island_info;  // an island's own settings (island_solver_settings.h)
  // The step's islands (build_islands): nodes are the owned bodies and
  // ghosts in id order (TerritoryWorld::nodes_), edges the manifolds with
  // points; held: each island's manifolds, by (id0, id1).
  IslandBuilder islands;
  IslandItems<btPersistentManifold*> held;
  IslandItems<btTypedConstraint*, JointId> joints;  // each island's joints that hold, by joint id
  BorderLink border_link;
  BorderIslandSolver border;  // the merged-island path (solve_border_island)
  IslandReplay replay;        // set_replay
  Statics statics;            // after the world: its detached copies are no Bullet objects
};

/// A component of this world's contact graph that waits for glue (it holds
/// a ghost or a body sent as a ghost): island `index` of Parts::islands.
struct TerritoryWorld::Component {
  int index = 0;                   // component number
  BodyId root = 0;                 // smallest id
  bool has_ghost = false;
  std::vector<LinkIn> links_in;
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
