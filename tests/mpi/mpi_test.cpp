// PartitionedWorld over MPI ranks (docs/mpi.md): run by ctest under
// `mpirun -np 2` and `-np 4` (label mpi). Every rank runs every test in the
// same order (the runs and their gathers are collective); rank 0 compares
// the gathered whole-scene hash with the one-world reference. The suite
// has its own main: MPI is initialised before GoogleTest runs.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../runtime/partitioned_test_util.h"
#include "../runtime/tiled_floor.h"
#include "soda/mpi/mpi_group.h"
#include "soda/mpi/mpi_session.h"
#include "soda/replay/replay_reader.h"
#include "soda/runtime/checkpoint.h"
#include "soda/runtime/run.h"
#include "soda/runtime/simulation.h"
#include "soda/worlds/watchdog.h"
#include "driver/testing_hooks.h"

namespace soda {
namespace {

std::shared_ptr<ProcessGroup> g_group;  // every test's; made once in main

struct Case {
  std::string scene;
  int n = 0;
  std::string partition = "kmeans";
  int territories = 2;
  int steps = 60;
  bool border_grid = false;
};

// Speculation's counters summed over every world (rank 0: every rank's).
struct SpeculationSums {
  std::uint64_t bets = 0, bets_lost = 0, rollbacks = 0;
};

// The partitioned run over the ranks; rank 0 checks its gathered hash
// against the one-world run (also the threaded 1-territory run's hash).
SpeculationSums expect_scene_hash(const Scene& s, const Case& c, PartitionedOptions options) {
  const TerritoryMap map =
      make_partition(c.partition, s, c.territories, c.border_grid ? test::border_grid() : GridOptions{});
  options.group = g_group;
  PartitionedWorld world(s, map, options);
  world.step(c.steps);
  const std::uint64_t hash = world.state_hash();  // collective
  const std::size_t bodies = world.body_count();  // collective
  SpeculationSums sums;
  for (const WorldMetrics& m : world.metrics()) {  // collective
    sums.bets += m.bets;
    sums.bets_lost += m.bets_lost;
    sums.rollbacks += m.rollbacks;
  }
  if (g_group->rank() != 0) return sums;
  EXPECT_EQ(bodies, s.bodies.size());
  const std::uint64_t reference = test::reference_hash(s, c.steps);
  std::printf("[ %s %d, %s K %d on %d ranks, anticipation %d ] %s (one world %s)\n", c.scene.c_str(), c.n,
              c.partition.c_str(), c.territories, g_group->size(), options.runtime.anticipation, hash_hex(hash).c_str(),
              hash_hex(reference).c_str());
  EXPECT_EQ(hash, reference) << c.scene << " " << c.partition << " K=" << c.territories << " on "
                             << g_group->size() << " ranks: " << hash_hex(hash) << " vs one world "
                             << hash_hex(reference);
  return sums;
}

SpeculationSums expect_reference_hash(const Case& c, PartitionedOptions options = {}) {
  return expect_scene_hash(test::scene(c.scene, c.n), c, options);
}

PartitionedOptions threads_per_world() {
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  return o;
}

TEST(Mpi, FallingCubesGiveTheOneWorldHash) {
  expect_reference_hash({"falling-cubes", 150, "kmeans", 2, 60}, threads_per_world());
  expect_reference_hash({"falling-cubes", 150, "kmeans", 4, 60}, threads_per_world());
}

TEST(Mpi, CubePileGivesTheOneWorldHash) {
  expect_reference_hash({"cube-pile", 100, "kmeans", 4, 60}, threads_per_world());
}

TEST(Mpi, BorderScenesGiveTheOneWorldHash) {
  // Towers on the plane x = 0 and on the corner where four territories meet.
  expect_reference_hash({"seam-stack", 0, "grid:2x1x2", 4, 120, true}, threads_per_world());
  // Spheres shuttling across three borders: migrations between ranks.
  expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 80}, threads_per_world());
}

TEST(Mpi, MoreTerritoriesThanRanksOnAPoolOrOneThread) {
  PartitionedOptions pool;
  pool.schedule = Schedule::Pool;
  pool.threads = 2;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 6, 50}, pool);
  PartitionedOptions one;  // Sequential: one pool worker per rank
  one.schedule = Schedule::Sequential;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 5, 50}, one);
}

TEST(Mpi, SerialisedAndFuzzedMessagesGiveTheOneWorldHash) {
  PartitionedOptions o = threads_per_world();
  o.serialise = true;
  detail::edit_testing_hooks(o).fuzz_seed = 11;
  expect_reference_hash({"cube-pile", 80, "kmeans", 4, 40}, o);
}

// Speculation over ranks: the commit horizon computed by the ranks together
// (Mattern's cut, mpi/src/gvt_rounds.h), notices and their pins between
// ranks, the rollback board numbered by rank 0. Eager bets: as many bets
// and lost bets as the scenes allow.
PartitionedOptions speculating(int anticipation = 8) {
  PartitionedOptions o = threads_per_world();
  o.runtime.anticipation = anticipation;
  o.runtime.eager_bets = true;
  return o;
}

void add(SpeculationSums& to, const SpeculationSums& s) {
  to.bets += s.bets;
  to.bets_lost += s.bets_lost;
  to.rollbacks += s.rollbacks;
}

TEST(Mpi, SpeculationGivesTheOneWorldHash) {
  SpeculationSums sums;
  add(sums, expect_reference_hash({"falling-cubes", 150, "kmeans", 4, 60}, speculating()));
  add(sums, expect_reference_hash({"cube-pile", 100, "kmeans", 4, 60}, speculating()));
  add(sums, expect_reference_hash({"seam-stack", 0, "grid:2x1x2", 4, 120, true}, speculating()));
  add(sums, expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 80}, speculating()));
  if (g_group->rank() != 0) return;
  EXPECT_GT(sums.bets, 0u);
  EXPECT_GT(sums.bets_lost, 0u) << "no bet was lost: nothing rolled back across ranks";
  EXPECT_GT(sums.rollbacks, 0u);
}

// Discard and recompute: every rollback is one of every world, posted on
// the board over ranks (rank 0 numbers it, every rank restores).
TEST(Mpi, RollbacksOfEveryWorldAcrossRanks) {
  PartitionedOptions o = speculating();
  o.runtime.rollback = PartitionedOptions::Rollback::Recompute;
  SpeculationSums sums;
  add(sums, expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 80}, o));
  add(sums, expect_reference_hash({"cube-pile", 100, "kmeans", 4, 60}, o));
  if (g_group->rank() != 0) return;
  EXPECT_GT(sums.rollbacks, 0u);
}

TEST(Mpi, SpeculationOnFewerRanksThanTerritories) {
  PartitionedOptions pool = speculating();
  pool.schedule = Schedule::Pool;
  pool.threads = 2;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 6, 50}, pool);
  PartitionedOptions one = speculating(64);
  one.schedule = Schedule::Sequential;  // one pool worker per rank
  one.runtime.checkpoint_every = 1;
  expect_reference_hash({"border-shuttle", 40, "grid:5x1x1", 5, 60}, one);
}

// Random pauses in every stage, before every send and delivery, and as
// notices are taken in: the horizon must hold while they are on the wire.
TEST(Mpi, SpeculationFuzzedGivesTheOneWorldHash) {
  for (std::uint64_t seed : {3u, 4u}) {
    PartitionedOptions o = speculating(seed == 3 ? 8 : 64);
    o.serialise = seed == 4;
    o.runtime.checkpoint_every = seed == 3 ? 8 : 1;
    detail::edit_testing_hooks(o).fuzz_seed = seed;
    expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 60}, o);
    expect_reference_hash({"cube-pile", 80, "kmeans", 4, 40}, o);
  }
}

// SyncTest over ranks: every step rolled back and re-run, each rank from
// its own worlds' kept parts, bit-identical (else it throws), ending on the
// one-world hash; lockstep and speculating.
TEST(Mpi, SyncTestGivesTheOneWorldHash) {
  PartitionedOptions lockstep = threads_per_world();
  lockstep.sync_test = 4;
  expect_reference_hash({"falling-cubes", 150, "kmeans", 4, 30}, lockstep);
  expect_reference_hash({"seam-stack", 0, "grid:2x1x2", 4, 30, true}, lockstep);
  PartitionedOptions spec = speculating();
  spec.sync_test = 3;
  expect_reference_hash({"cube-pile", 100, "kmeans", 4, 30}, spec);
  expect_reference_hash({"border-shuttle", 40, "grid:4x1x1", 4, 30}, spec);
}

// What an application's scene has beyond free convex bodies, over ranks:
// level geometry (a heightfield, a triangle mesh, compound shapes), joints
// (fragments and migrants carry them between ranks; a jointed group moves
// whole) and kinematic bodies on scene paths; lockstep and speculating.
TEST(Mpi, LevelGeometryJointsAndKinematicBodiesGiveTheOneWorldHash) {
  for (const PartitionedOptions& o : {threads_per_world(), speculating()}) {
    expect_reference_hash({"terrain", 40, "kmeans", 4, 60}, o);
    expect_reference_hash({"city", 40, "kmeans", 4, 60}, o);
    expect_reference_hash({"compounds", 30, "kmeans", 4, 60}, o);
    expect_reference_hash({"pendulums", 8, "grid:2x1x1", 2, 80}, o);
    expect_reference_hash({"chain-bridge", 12, "grid:4x1x1", 4, 80}, o);
    expect_reference_hash({"ragdolls", 6, "kmeans", 4, 80}, o);
    expect_reference_hash({"conveyor", 48, "kmeans", 4, 80}, o);
  }
}

// Level geometry over ranks: a rank's worlds hold the part of the terrain's
// heightfield and of the city's mesh near their cells (scene_share.h), on
// 4 ranks less than the whole on every rank, and the gathered hash is the
// one world's (the test above); a snapshot, which no rank could write
// whole, is refused alike on every rank, naming the body.
TEST(Mpi, ARankHoldsThePartOfTheLevelGeometryNearItsWorlds) {
  for (const char* name : {"terrain", "city"}) {
    const Scene s = test::scene(name, 40);
    std::size_t whole = 0;
    for (const Body& b : s.bodies) {
      if (b.shape.kind == ShapeKind::TriangleMesh) whole += b.shape.mesh->triangles.size();
      if (b.shape.kind == ShapeKind::Heightfield) whole += b.shape.heightfield->heights.size();
    }
    ASSERT_GT(whole, 0u) << name;
    PartitionedOptions o = threads_per_world();
    o.group = g_group;
    PartitionedWorld world(s, make_partition("kmeans", s, 4, GridOptions{}), o);
    world.step(20);
    std::size_t held = 0;
    bool cut = false;
    for (WorldId w = 0; w < world.world_count() && held == 0; ++w) {
      if (g_group->rank_of(w, world.world_count()) != g_group->rank()) continue;
      for (const BodySnapshot& b : world.world(w).static_snapshots()) {
        const Shape& shape = b.description.shape;
        if (shape.kind == ShapeKind::TriangleMesh) held += shape.mesh->triangles.size(), cut |= !!shape.mesh->cut;
        if (shape.kind == ShapeKind::Heightfield)
          held += shape.heightfield->heights.size(), cut |= shape.heightfield->window.columns != 0;
      }
    }
    std::printf("[ %s 40, K 4, rank %d of %d ] its worlds hold %zu of the %zu %s\n", name, g_group->rank(),
                g_group->size(), held, whole, s.bodies.front().shape.kind == ShapeKind::Heightfield ? "samples" : "triangles");
    if (g_group->size() == 4) {
      EXPECT_LT(held, whole) << name << ", rank " << g_group->rank();
      EXPECT_TRUE(cut) << name;
    }
    const std::size_t bodies = world.body_count();  // collective; rank 0's is the gathered count
    if (g_group->rank() == 0) {
      EXPECT_EQ(bodies, s.bodies.size());
    }
    if (g_group->size() == 4) {
      try {
        (void)world.snapshot();  // collective
        ADD_FAILURE() << name << ": a snapshot of a cut scene was written";
      } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("only a part of"), std::string::npos) << e.what();
      }
    }
  }
}

// A floor of 361 static tiles under a pile: each world, on whichever rank,
// holds the tiles near its cells (docs/partitioned-step.md, §2a), the other
// ranks' worlds that a rank builds but never steps hold none, and the
// gathered hash is the one world's.
TEST(Mpi, TiledFloorGivesTheOneWorldHashWithEachWorldsTiles) {
  const Scene s = test::tiled_floor(test::scene("cube-pile", 160), 1.5);
  for (const PartitionedOptions& o : {threads_per_world(), speculating()}) {
    const Case c{"tiled cube-pile", 160, "grid:2x1x2", 4, 80};
    expect_scene_hash(s, c, o);
    PartitionedOptions again = o;
    again.group = g_group;
    PartitionedWorld world(s, make_partition("grid:2x1x2", s, 4, GridOptions{}), again);
    world.step(20);
    std::size_t held = 0;
    for (const WorldMetrics& m : world.metrics()) held += m.statics_held;  // collective
    std::size_t mine = 0;
    for (WorldId w = 0; w < world.world_count(); ++w) {
      if (g_group->rank_of(w, world.world_count()) == g_group->rank())
        mine += world.world(w).held_static_count();
      else
        EXPECT_EQ(world.world(w).held_static_count(), 0u) << "rank " << g_group->rank() << ", world " << w;
    }
    std::printf("[ tiled cube-pile 160, K 4, rank %d ] its worlds hold %zu tiles\n", g_group->rank(), mine);
    if (g_group->size() == 4) EXPECT_LT(mine, s.static_count());  // a quarter of the floor and its ring
    if (g_group->rank() == 0) {
      std::printf("[ tiled cube-pile 160, K 4 on %d ranks ] %zu tiles, %zu held over the worlds\n", g_group->size(),
                  s.static_count(), held);
      EXPECT_LT(held, 4 * s.static_count());
      EXPECT_GE(held, s.static_count());
    }
  }
}

// A rank builds its worlds from its share of the scene (scene_share.h): the
// worlds it steps own what the threaded run's do, the others no body (the
// kinematic ones aside, which every world holds); the hash is one world's.
TEST(Mpi, ARankBuildsItsWorldsFromItsShareOfTheScene) {
  for (const char* name : {"falling-cubes", "ragdolls", "conveyor"}) {
    const Scene s = test::scene(name, 120);
    const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
    PartitionedOptions o = threads_per_world();
    o.group = g_group;
    const PartitionedWorld ranked(s, map, o);
    const PartitionedWorld threaded(s, map, threads_per_world());
    std::size_t kinematic = 0;
    for (const Body& b : s.bodies) kinematic += b.kinematic;
    std::size_t mine = 0;
    for (WorldId w = 0; w < ranked.world_count(); ++w) {
      if (g_group->rank_of(w, ranked.world_count()) == g_group->rank()) {
        EXPECT_EQ(ranked.world(w).owned_ids(), threaded.world(w).owned_ids()) << name << ", world " << w;
        mine += ranked.world(w).owned_count();
      } else {
        EXPECT_EQ(ranked.world(w).owned_count(), 0u) << name << ", world " << w;
        EXPECT_EQ(ranked.world(w).bullet_object_count(), kinematic) << name << ", world " << w;
      }
    }
    std::printf("[ %s 120, K 4, rank %d of %d ] its worlds own %zu of %zu dynamic bodies\n", name, g_group->rank(),
                g_group->size(), mine, s.dynamic_count());
    expect_scene_hash(s, Case{name, 120, "kmeans", 4, 40}, threads_per_world());
  }
}

// A world that throws on one rank stops the run on every rank, each with the
// failing world's error; nobody hangs (ctest's timeout would say so).
void expect_failure_stops_every_rank(PartitionedOptions o) {
  const Scene s = test::scene("cube-pile", 100);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  o.runtime.watchdog.response = WatchdogResponse::Stop;
  o.group = g_group;
  // A body of the world on the last rank: its rank fails, the others are told.
  BodyId body = 0;
  const WorldId w = 3;
  for (const Body& b : s.bodies)
    if (!b.is_static && map.owner_of(b.position) == w) body = b.id;
  ASSERT_NE(body, 0);
  detail::edit_testing_hooks(o).inject_fault = {10, body};
  PartitionedWorld world(s, map, o);
  try {
    world.step(40);
    ADD_FAILURE() << "rank " << g_group->rank() << ": expected the run to stop with world " << w << "'s error";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("watchdog: step 10"), std::string::npos) << "rank " << g_group->rank() << ": " << what;
    if (g_group->rank_of(w, 4) != g_group->rank()) {
      EXPECT_NE(what.find("rank " + std::to_string(g_group->rank_of(w, 4)) + " failed: world 3"), std::string::npos)
          << what;
    }
  }
}

TEST(Mpi, AFailingRankStopsEveryRankWithItsError) { expect_failure_stops_every_rank(threads_per_world()); }

TEST(Mpi, AFailingRankStopsEveryRankWhileSpeculating) { expect_failure_stops_every_rank(speculating()); }

// Inputs known before the run (PartitionedOptions::inputs; `soda run
// --inputs` under mpirun): every rank holds them all, and each world applies
// those that concern it at their boundary. The gathered hash and body count
// are the one-territory run's given the same inputs (every rank runs that
// one alone), lockstep and speculating: bodies pushed, made heavy, given a
// velocity, a pose and a collision filter, the gravity turned, a body
// removed and one added; on the pendulums, a joint removed; on the
// conveyor, a kinematic pallet's filter changed and changed back.
void expect_inputs_give_the_one_territory_hash(const Case& c, const std::vector<UserInput>& inputs,
                                                bool validate = false, const std::string& policy = "none") {
  const Scene s = test::scene(c.scene, c.n);
  PartitionedOptions alone;
  alone.inputs = inputs;
  PartitionedWorld one(s, make_partition("kmeans", s, 1, GridOptions{}), alone);
  one.step(c.steps);
  for (PartitionedOptions o : {threads_per_world(), speculating()}) {
    o.inputs = inputs;
    o.group = g_group;
    o.runtime.validate = validate;
    o.runtime.balance.policy = policy;
    o.runtime.balance.period = 10;
    PartitionedWorld world(s, make_partition(c.partition, s, c.territories, GridOptions{}), o);
    world.step(c.steps);
    const std::uint64_t hash = world.state_hash();  // collective
    const std::size_t bodies = world.body_count();  // collective
    if (g_group->rank() != 0) continue;
    std::printf("[ %s %d with %zu inputs, --lb %s, K %d on %d ranks, anticipation %d ] %s, %zu bodies (one territory "
                "%s, %zu)\n",
                c.scene.c_str(), c.n, inputs.size(), policy.c_str(), c.territories, g_group->size(),
                o.runtime.anticipation, hash_hex(hash).c_str(), bodies, hash_hex(one.state_hash()).c_str(),
                one.body_count());
    EXPECT_EQ(hash_hex(hash), hash_hex(one.state_hash())) << c.scene << " anticipation " << o.runtime.anticipation;
    EXPECT_EQ(bodies, one.body_count());
    EXPECT_NE(hash_hex(hash), hash_hex(test::reference_hash(s, c.steps)));  // the inputs changed the run
  }
}

UserInput input(UserInput::Kind kind, std::int64_t step, BodyId id) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  return in;
}

// Inputs of every kind a body takes, cube-pile 100: a push, a mass, a
// velocity, a filter, the gravity, a pose, a removal and an addition.
std::vector<UserInput> body_inputs() {
  std::vector<UserInput> bodies;
  UserInput push = input(UserInput::Kind::ApplyImpulse, 10, 5);
  push.linear = Vec3(0, 30, 0);
  UserInput heavy = input(UserInput::Kind::SetMass, 12, 11);
  heavy.value = 5.0;
  UserInput fast = input(UserInput::Kind::SetVelocity, 15, 7);
  fast.linear = Vec3(2, 0, 0);
  UserInput ghost = input(UserInput::Kind::SetCollisionFilter, 20, 4);
  ghost.collision_group = 16u, ghost.collision_mask = 0u;
  UserInput tilt = input(UserInput::Kind::SetGravity, 25, 0);
  tilt.linear = Vec3(1, -9.81, 0);
  UserInput moved = input(UserInput::Kind::SetPose, 30, 13);
  moved.linear = Vec3(0.5, 6.0, 0.5);
  UserInput added = input(UserInput::Kind::AddBody, 40, 0);
  added.body.id = 500;
  added.body.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
  added.body.position = Vec3(0, 8, 0);
  bodies = {push, heavy, fast, ghost, tilt, moved, input(UserInput::Kind::RemoveBody, 35, 9), added};
  for (std::size_t i = 0; i < bodies.size(); ++i) bodies[i].sequence = i;
  return bodies;
}

// Load balancing over ranks (--lb): every rank gathers every world's loads
// (its step records and held pairs) so that its policy decides the same
// moves, the worlds a cession changes are rebuilt from the gathered state
// (another rank's empty), and the hash is the one world's under every
// policy, lockstep and speculating; cells do move. A balanced run keeps
// its level geometry whole on every rank (cells change worlds).
void expect_balanced_hash(const Case& c, const std::string& policy, PartitionedOptions o) {
  const Scene s = test::scene(c.scene, c.n);
  o.runtime.balance.policy = policy;
  o.runtime.balance.period = 10;
  o.group = g_group;
  PartitionedWorld world(s, make_partition(c.partition, s, c.territories, GridOptions{}), o);
  world.step(c.steps);
  const std::uint64_t hash = world.state_hash();  // collective
  std::int64_t moved = 0;
  for (const BalanceRecord& r : world.balance_log()) moved += r.cells_moved;
  // Every rank's policy decided the same moves.
  std::vector<std::uint8_t> mine(reinterpret_cast<const std::uint8_t*>(&moved),
                                 reinterpret_cast<const std::uint8_t*>(&moved) + sizeof moved);
  const std::vector<std::vector<std::uint8_t>> all = g_group->all_gather(mine);
  for (const std::vector<std::uint8_t>& other : all) EXPECT_EQ(other, mine) << c.scene << " --lb " << policy;
  if (g_group->rank() != 0) return;
  const std::uint64_t reference = test::reference_hash(s, c.steps);
  std::printf("[ %s %d, --lb %s, K %d on %d ranks, anticipation %d ] %zu balance steps, %lld cells moved: %s (one "
              "world %s)\n",
              c.scene.c_str(), c.n, policy.c_str(), c.territories, g_group->size(), o.runtime.anticipation,
              world.balance_log().size(), static_cast<long long>(moved), hash_hex(hash).c_str(),
              hash_hex(reference).c_str());
  EXPECT_EQ(hash_hex(hash), hash_hex(reference)) << c.scene << " --lb " << policy;
  if (c.scene == "hotspot" || policy == "churn") EXPECT_GT(moved, 0) << c.scene << " --lb " << policy;
}

// Inputs and load balancing together over ranks: bodies added and removed
// while cells change worlds.
TEST(Mpi, InputsWithLoadBalancingGiveTheOneTerritoryHash) {
  for (const char* policy : {"churn", "diffusive"})
    expect_inputs_give_the_one_territory_hash({"cube-pile", 100, "grid:2x1x2", 4, 60}, body_inputs(), false, policy);
}

TEST(Mpi, LoadBalancingGivesTheOneWorldHashUnderEveryPolicy) {
  for (PartitionedOptions o : {threads_per_world(), speculating()}) {
    for (const char* policy : {"diffusive", "rcb", "churn"}) {
      expect_balanced_hash({"hotspot", 300, "grid:4x1x1", 4, 60}, policy, o);
      expect_balanced_hash({"cube-pile", 100, "grid:2x1x2", 4, 40}, policy, o);
      expect_balanced_hash({"falling-cubes", 200, "kmeans", 4, 40}, policy, o);
    }
    expect_balanced_hash({"terrain", 100, "kmeans", 4, 40}, "churn", o);  // its heightfield whole on every rank
    expect_balanced_hash({"drift", 200, "grid:4x1x1", 4, 60}, "rcb", o);
    expect_balanced_hash({"alternating-load", 300, "grid:4x1x1", 4, 60}, "diffusive", o);
  }
}

// Validation over ranks (--validate): after every step, every rank's
// worlds' census (one owner a body, none lost, one holder a contact pair,
// Bullet's object counts) gathered and checked alike on every rank, with
// the bodies inputs add and remove expected at their step; the hash stays
// the one world's. Lockstep and speculating, level geometry cut per rank.
TEST(Mpi, ValidationChecksEveryRanksWorldsAtEveryStep) {
  for (PartitionedOptions o : {threads_per_world(), speculating()}) {
    o.runtime.validate = true;
    expect_reference_hash({"cube-pile", 100, "kmeans", 4, 70}, o);
    expect_reference_hash({"terrain", 40, "kmeans", 4, 40}, o);
    expect_reference_hash({"ragdolls", 6, "kmeans", 4, 40}, o);
  }
  expect_inputs_give_the_one_territory_hash({"cube-pile", 100, "kmeans", 4, 80}, body_inputs(), true);
}

TEST(Mpi, InputsGiveTheOneTerritoryHash) {
  expect_inputs_give_the_one_territory_hash({"cube-pile", 100, "kmeans", 4, 80}, body_inputs());

  const Scene pendulums = test::scene("pendulums", 8);
  UserInput cut;
  cut.kind = UserInput::Kind::RemoveJoint;
  cut.step = 20;
  cut.joint = pendulums.joints.at(3).id;
  expect_inputs_give_the_one_territory_hash({"pendulums", 8, "grid:2x1x1", 2, 80}, {cut});

  // A kinematic pallet (body 2) touches nothing from 30 to 40: its boxes
  // drop into it; every rank keeps the filter as a command of its step.
  UserInput open = input(UserInput::Kind::SetCollisionFilter, 30, 2);
  open.collision_group = kDefaultCollisionGroup, open.collision_mask = 0u;
  UserInput closed = input(UserInput::Kind::SetCollisionFilter, 40, 2);
  closed.sequence = 1;
  expect_inputs_give_the_one_territory_hash({"conveyor", 48, "kmeans", 4, 80}, {open, closed});
}

// snapshot() over ranks: every rank gets the whole scene's state, the bits
// of the threaded run's snapshot at that step (bodies, contact state,
// joints; the kinematic bodies as the rank stepping world 0 has them), and
// a run restored from it goes on as the threaded run does.
TEST(Mpi, SnapshotGathersTheWholeSceneOnEveryRank) {
  for (const Case& c : {Case{"cube-pile", 100, "kmeans", 4, 50}, Case{"ragdolls", 6, "kmeans", 4, 60},
                        Case{"conveyor", 48, "kmeans", 4, 40}})
    for (PartitionedOptions o : {threads_per_world(), speculating()}) {
      const Scene s = test::scene(c.scene, c.n);
      const TerritoryMap map = make_partition(c.partition, s, c.territories, GridOptions{});
      PartitionedWorld threaded(s, map);
      threaded.step(c.steps);
      o.group = g_group;
      PartitionedWorld ranked(s, map, o);
      ranked.step(c.steps);
      const WorldSnapshot gathered = ranked.snapshot();  // collective
      const WorldSnapshot expected = threaded.snapshot();
      EXPECT_TRUE(same_bits(gathered, expected))
          << c.scene << " on rank " << g_group->rank() << ", anticipation " << o.runtime.anticipation << ": "
          << gathered.bodies.size() << " bodies, " << gathered.manifolds.size() << " manifolds, "
          << gathered.joints.size() << " joints (threaded " << expected.bodies.size() << ", "
          << expected.manifolds.size() << ", " << expected.joints.size() << ")";
      EXPECT_FALSE(gathered.manifolds.empty()) << c.scene;
      PartitionedWorld restored(gathered, map);
      restored.step(20);
      threaded.step(20);
      EXPECT_EQ(hash_hex(restored.state_hash()), hash_hex(threaded.state_hash())) << c.scene;
      if (g_group->rank() == 0)
        std::printf("[ %s %d, K 4 on %d ranks, anticipation %d ] snapshot at step %d: %zu bodies, %zu manifolds, "
                    "%zu joints, the threaded run's bits; restored, 20 steps on: %s\n",
                    c.scene.c_str(), c.n, g_group->size(), o.runtime.anticipation, c.steps, gathered.bodies.size(),
                    gathered.manifolds.size(), gathered.joints.size(), hash_hex(restored.state_hash()).c_str());
    }
}

// --record over ranks: rank 0 writes, from the poses every rank sends it
// after each step, the replay the threaded run of the same configuration
// records: every frame's bodies, poses, sleep flags and owners, the map,
// and on the last frame the state hash (busy times aside: they are
// measured). With inputs (a body added and one removed: frames with ids),
// lockstep and speculating.
void expect_recording_as_on_threads(const std::string& scene, int n, const std::vector<UserInput>& inputs,
                                    int anticipation) {
  const Scene s = test::scene(scene, n);
  RunConfig config;
  config.territories = 4;
  config.steps = 70;
  config.progress_seconds = 0;
  config.runtime.anticipation = anticipation;
  if (!inputs.empty()) config.inputs = inputs;
  const std::string stem = ::testing::TempDir() + "mpi_record_" + scene + "_np" + std::to_string(g_group->size()) +
                           "_a" + std::to_string(anticipation) + "_" + std::to_string(sizeof(btScalar));
  RunConfig on_ranks = config;
  on_ranks.record_path = stem + "_ranks.replay";
  on_ranks.group = g_group;
  const RunResult r = run_scene(s, on_ranks);  // collective
  if (g_group->rank() != 0) return;
  RunConfig on_threads = config;
  on_threads.record_path = stem + "_threads.replay";
  const RunResult t = run_scene(s, on_threads);
  EXPECT_EQ(hash_hex(r.state_hash), hash_hex(t.state_hash));
  EXPECT_EQ(r.record_frames, static_cast<std::uint64_t>(config.steps + 1));
  replay::ReplayReader a(on_ranks.record_path), b(on_threads.record_path);
  ASSERT_EQ(a.frame_count(), b.frame_count());
  ASSERT_EQ(a.added_bodies().size(), b.added_bodies().size());
  int with_ids = 0;
  for (std::int64_t k = 0; k <= config.steps; ++k) {
    const std::optional<replay::ViewFrame> x = a.frame_at(k), y = b.frame_at(k);
    ASSERT_TRUE(x && y) << "step " << k;
    with_ids += x->ids.has_value();
    EXPECT_EQ(x->ids, y->ids) << "step " << k;
    EXPECT_EQ(x->position, y->position) << "step " << k;
    EXPECT_EQ(x->orientation, y->orientation) << "step " << k;
    EXPECT_EQ(x->sleeping, y->sleeping) << "step " << k;
    EXPECT_EQ(x->owner, y->owner) << "step " << k;
    EXPECT_EQ(x->cell_owner, y->cell_owner) << "step " << k;
    EXPECT_EQ(x->state_hash, y->state_hash) << "step " << k;
    EXPECT_EQ(x->world_busy_ms.size(), k == 0 ? 0u : 4u) << "step " << k;
  }
  const std::optional<replay::ViewFrame> last = a.frame_at(config.steps);
  ASSERT_TRUE(last && last->state_hash);
  std::printf("[ %s %d with %zu inputs, K 4 on %d ranks, anticipation %d, --record ] %zu frames (%d with ids), "
              "last frame %s, threaded %s\n",
              scene.c_str(), n, inputs.size(), g_group->size(), anticipation, a.frame_count(), with_ids,
              hash_hex(*last->state_hash).c_str(), hash_hex(t.state_hash).c_str());
  EXPECT_EQ(hash_hex(*last->state_hash), hash_hex(t.state_hash));
  EXPECT_EQ(with_ids > 0, !inputs.empty());
}

// --checkpoint over ranks: rank 0 writes, at the step asked, the file the
// threaded run writes there, byte for byte: the whole scene's state, the
// inputs still to come (an addition at 40), the ids removed before (9, at
// 35). Resumed from it, a Simulation on threads and a run over the ranks
// (--resume, on another territory count) end on the uninterrupted run's
// hash; the resumed run's own checkpoint at 50 is the threaded run's file
// at 50. Lockstep and speculating.
std::vector<char> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void expect_checkpoint_as_on_threads(int anticipation) {
  const Scene s = test::scene("cube-pile", 100);
  RunConfig config;
  config.territories = 4;
  config.steps = 70;
  config.checkpoint_at = 37;
  config.progress_seconds = 0;
  config.runtime.anticipation = anticipation;
  config.inputs = body_inputs();
  const std::string stem = ::testing::TempDir() + "mpi_checkpoint_np" + std::to_string(g_group->size()) + "_a" +
                           std::to_string(anticipation) + "_" + std::to_string(sizeof(btScalar));
  RunConfig on_ranks = config;
  on_ranks.checkpoint_path = stem + "_ranks.checkpoint";
  on_ranks.group = g_group;
  const RunResult r = run_scene(s, on_ranks);  // collective
  EXPECT_EQ(r.checkpoint_step, 37);
  // Resumed over the ranks from the file rank 0 wrote (written before any
  // rank went on: checkpoint_on_ranks agrees on the write).
  RunConfig again;
  again.territories = 3;
  again.steps = config.steps;
  again.progress_seconds = 0;
  again.runtime.anticipation = anticipation;
  again.resume = std::make_shared<const SimulationSnapshot>(read_checkpoint(on_ranks.checkpoint_path));
  again.group = g_group;
  again.checkpoint_at = 50;  // and saved again, after the addition: the retired id 9 carried on
  again.checkpoint_path = stem + "_again.checkpoint";
  const RunResult resumed_on_ranks = run_scene(scene_of(again.resume->state), again);  // collective
  EXPECT_EQ(resumed_on_ranks.resumed_at, 37);
  if (g_group->rank() != 0) return;
  EXPECT_EQ(hash_hex(resumed_on_ranks.state_hash), hash_hex(r.state_hash));
  EXPECT_EQ(resumed_on_ranks.checkpoint_step, 50);
  RunConfig at_50 = config;
  at_50.checkpoint_at = 50;
  at_50.checkpoint_path = stem + "_threads_50.checkpoint";
  run_scene(s, at_50);
  EXPECT_EQ(file_bytes(again.checkpoint_path), file_bytes(at_50.checkpoint_path));  // byte for byte
  EXPECT_EQ(read_checkpoint(again.checkpoint_path).retired_ids, std::vector<BodyId>{9});
  RunConfig on_threads = config;
  on_threads.checkpoint_path = stem + "_threads.checkpoint";
  const RunResult t = run_scene(s, on_threads);
  EXPECT_EQ(hash_hex(r.state_hash), hash_hex(t.state_hash));
  const SimulationSnapshot a = read_checkpoint(on_ranks.checkpoint_path);
  const SimulationSnapshot b = read_checkpoint(on_threads.checkpoint_path);
  EXPECT_TRUE(same_bits(a.state, b.state));
  EXPECT_EQ(file_bytes(on_ranks.checkpoint_path), file_bytes(on_threads.checkpoint_path));  // byte for byte
  ASSERT_EQ(a.inputs.size(), b.inputs.size());
  for (std::size_t i = 0; i < a.inputs.size(); ++i) {
    EXPECT_EQ(a.inputs[i].kind, b.inputs[i].kind) << i;
    EXPECT_EQ(a.inputs[i].step, b.inputs[i].step) << i;
    EXPECT_EQ(a.inputs[i].body.id, b.inputs[i].body.id) << i;
  }
  EXPECT_EQ(a.retired_ids, b.retired_ids);
  EXPECT_EQ(a.retired_ids, std::vector<BodyId>{9});
  EXPECT_EQ(a.retired_joint_ids, b.retired_joint_ids);
  SimulationConfig resumed_config{.territories = 2, .buffer_capacity = 16};
  Simulation resumed = Simulation::resume(on_ranks.checkpoint_path, resumed_config);
  ASSERT_TRUE(resumed.advance_to(resumed.time_of(config.steps)));
  std::printf("[ cube-pile 100 with 8 inputs, K 4 on %d ranks, anticipation %d, --checkpoint-at 37 ] %llu bytes, "
              "the threaded run's file; resumed on 2 threads: %s, on K 3 over the ranks: %s, uninterrupted %s\n",
              g_group->size(), anticipation, static_cast<unsigned long long>(r.checkpoint_bytes),
              hash_hex(resumed.state_hash()).c_str(), hash_hex(resumed_on_ranks.state_hash).c_str(),
              hash_hex(t.state_hash).c_str());
  EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(t.state_hash));
  resumed.stop();
}

TEST(Mpi, CheckpointGivesTheThreadedOneAndResumesOnThreads) {
  expect_checkpoint_as_on_threads(0);
  expect_checkpoint_as_on_threads(8);
}

TEST(Mpi, RecordingGivesTheThreadedReplay) {
  expect_recording_as_on_threads("falling-cubes", 120, {}, 0);
  expect_recording_as_on_threads("cube-pile", 100, body_inputs(), 0);
  expect_recording_as_on_threads("cube-pile", 100, body_inputs(), 8);
}

}  // namespace
}  // namespace soda

int main(int argc, char** argv) {
  soda::MpiSession mpi(&argc, &argv);
  testing::InitGoogleTest(&argc, argv);
  soda::g_group = soda::make_mpi_group();
  // Every rank reports (a failure on rank 1 is printed by rank 1); mpirun
  // fails the job if any rank returns non-zero.
  const int failed = RUN_ALL_TESTS();
  soda::g_group.reset();
  return failed;
}
