// Internal: the merged-island path of a territory world (territory_world.h,
// docs/partitioned-step.md): a border island — one whose fragments lie in
// several worlds — solved once, by its root, from every fragment of it, and
// its result kept by every world involved. Three verbs, in the order of a
// step:
//
//   note_own_fragment / hold   border_fragments(): this world's fragments of
//                              the step and the manifolds they hold, by key
//   solve                      the root: every fragment of one island in,
//                              the island's result out (own fragments are
//                              taken and solved in place, at most once each)
//   apply                      every world of the island: its part of the
//                              result (its bodies, the manifolds it holds,
//                              the ones it keeps that others hold)
//
// Invariants:
//  1. solve() is a pure function of the island's fragments, whichever world
//     computes it and in whatever order the fragments come: bodies by id,
//     manifolds by (id0, id1), joints by joint id (each fragment carries
//     the joints it holds; on copies a joint is a constraint built afresh
//     from its description, which is all a joint's step reads besides its
//     bodies: joint_factory.h), one solveGroup as the canonical world
//     solves an island (DESIGN.md §2);
//  2. this world's own fragment is solved in place, its bodies and held
//     manifolds the originals, bit for bit as on copies: a copy is written
//     from the very state the fragment read from the original
//     (docs/coloured-solve.md, "The root's own share in place"); a held
//     manifold with a ghost at one end points at the copy of the ghost's
//     body during the solve and at its own bodies again after, however the
//     solve ends;
//  3. an own fragment is taken at most once, and only if it is the one
//     note_own_fragment() noted (same component, same manifolds), else
//     std::logic_error;
//  4. a body in two fragments (two owners) or a pair held twice is a
//     PartitionError naming the world, the step and the island.
//
// Thread safety: one solver per world, used by its stepping thread; the
// solve shares its loops with the world's SolverPool (each task writes only
// its own bodies and manifolds).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "coloured_solver.h"
#include "soda/worlds/border_records.h"
#include "soda/worlds/territory_counters.h"

namespace soda {

class SolverPool;

/// What the solver needs of the world it works for.
class BorderIslandHost {
 public:
  virtual ~BorderIslandHost() = default;
  /// Component `component` of the step's contact graph: its bodies (owned
  /// and ghosts, ascending id) and the manifolds it holds, by (id0, id1).
  virtual btCollisionObject* const* component_bodies(int component, int& count) const = 0;
  virtual btPersistentManifold* const* component_manifolds(int component, int& count) const = 0;
  /// True if the body is owned here (not a ghost).
  virtual bool owns_body(const btCollisionObject* body) const = 0;
  /// A static body by id, or null.
  virtual btCollisionObject* static_body(BodyId id) const = 0;
  /// An owned body by id, or null.
  virtual btRigidBody* owned_body(BodyId id) const = 0;
  /// True if this world keeps the contact state of pair (id0, id1) when
  /// another world holds it (it owns the pair's key body).
  virtual bool keeps_pair(BodyId id0, BodyId id1) const = 0;
  /// The constraint of a joint held here (its ends are this world's own
  /// bodies or statics), or null.
  virtual btTypedConstraint* held_joint(JointId id) const = 0;
  /// A joint held here broke in an island solved on copies.
  virtual void break_joint(JointId id) = 0;
};

/// The Bullet objects a solve runs with (the world's).
struct BorderIslandTools {
  ColouredSolver& solver;
  btCollisionDispatcher& dispatcher;
  const btContactSolverInfo& info;   // the world's solver info
  btContactSolverInfo& island_info;  // scratch: an island's own settings
  SolverPool* pool = nullptr;
};

class BorderIslandSolver {
 public:
  using PairKey = std::pair<BodyId, BodyId>;

  BorderIslandSolver(WorldId world, BorderIslandHost& host) : world_(world), host_(host) {}

  /// border_fragments(): forgets the last step's fragments.
  void begin_fragments();
  /// This world's fragment with root `root` is component `component`.
  void note_own_fragment(BodyId root, int component) { own_fragments_.emplace_back(root, component); }
  /// A manifold a fragment of this step holds (for apply).
  void hold(const PairKey& key, btPersistentManifold* manifold) { held_by_key_.emplace_back(key, manifold); }
  /// After the last hold(): throws std::logic_error if a pair is held twice.
  void end_fragments();

  /// The island's result from all its fragments (this world's included).
  /// `step`: for messages. Counts into `counters` (islands_solved,
  /// merged_island_bodies(_in_place), substepped_islands).
  IslandResult solve(const std::vector<const Fragment*>& island, const BorderIslandTools& tools, std::int64_t step,
                     TerritoryCounters& counters);
  /// This world's part of an island's result: owned bodies, held manifolds
  /// (both left alone if the island was solved in place here), and the
  /// contact state of pairs it keeps that others hold, into `kept`
  /// (speculative points and emptied manifolds are no contact state).
  void apply(const IslandResult& result, std::map<PairKey, ManifoldState>& kept, TerritoryCounters& counters);
  /// After the step's last island.
  void end_step();

 private:
  struct Copy {
    std::shared_ptr<btCollisionShape> shape;
    std::unique_ptr<btRigidBody> body;
    Body description;  // what the copy's mass, friction and restitution were made from
  };
  // One body of the island, its sort key beside it (comparing through the
  // pointers missed the cache at every step of the sort; this runs on the
  // root alone). `original`: this world's own body, solved in place.
  struct IslandBody {
    BodyId id;
    const BodyRecord* record;
    btRigidBody* original;
  };
  struct IslandManifold {
    PairKey key;
    const ManifoldState* state;
    btPersistentManifold* original;  // held here: solved in place
  };
  struct IslandJoint {
    const Joint* description;
    btTypedConstraint* original;  // held here, its fragment solved in place
  };
  // The island's bodies and manifolds, sorted, as the fragments give them.
  struct Gathered {
    std::vector<IslandBody> bodies;
    std::vector<IslandManifold> manifolds;
    std::vector<IslandJoint> joints;  // by joint id
    std::vector<BodyId> ids;  // bodies' ids, for searches
    bool any_in_place = false, copied_own = false;
    WorldId world = kNoWorld;
    std::int64_t step = 0;
    [[noreturn]] void fail(const std::string& what) const;  // PartitionError (invariant 4)
  };
  int take_own_fragment(const Fragment& f);
  void gather(const std::vector<const Fragment*>& island, std::int64_t step, Gathered& g);
  void place_bodies(const Gathered& g, SolverPool* pool, std::vector<btCollisionObject*>& bodies);
  void solve_awake(const Gathered& g, std::vector<btCollisionObject*>& bodies, const BorderIslandTools& tools,
                   IslandResult& result, TerritoryCounters& counters);

  WorldId world_;
  BorderIslandHost& host_;
  // This step's own fragments by (root, component): each solved in place at
  // most once, then its island noted in solved_in_place_ for apply().
  std::vector<std::pair<BodyId, int>> own_fragments_;
  std::vector<BodyId> solved_in_place_;
  // The manifolds held in this step's fragments, sorted by key (a flat
  // vector: a std::map's node per manifold and its lookups were ~1.5 % of a
  // partitioned cube-pile's CPU).
  std::vector<std::pair<PairKey, btPersistentManifold*>> held_by_key_;
  // Copies of other worlds' bodies and manifolds, by id, reused from step
  // to step (a manifold copy is reset to a fresh manifold's state before use).
  std::unordered_map<BodyId, std::unique_ptr<Copy>> copies_;
  std::vector<std::unique_ptr<btPersistentManifold>> manifold_copies_;
};

}  // namespace soda
