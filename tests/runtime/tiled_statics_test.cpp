// A territory world holds the fixed statics its pairs may meet, not every
// static of the scene (worlds/src/static_catalog.h): those that overlap its
// own cells dilated by the reach, any other that an owned body's halo or a
// joint reaches, and, for the root of a merged island, copies of those a
// fragment's manifold names. A pile of cubes dropped on a floor of 361 tilted
// static tiles ends with the one-world hash over the decomposition matrix
// and under churn; with more than one territory no world holds every tile,
// and merged islands are solved with copies of tiles their root lacks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "runtime/partitioned_test_util.h"
#include "runtime/tiled_floor.h"
#include "soda/loadbalance/policy.h"
#include "soda/runtime/balance_log.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 150;
constexpr double kTile = 1.5;  // m: a tile's pitch

// cube-pile 160 on a floor of tiles 1.5 m apart.
const Scene& tiled_pile() {
  static const Scene s = test::tiled_floor(test::scene("cube-pile", 160), kTile);
  return s;
}

// The tiled pile with a ball flying at 200 m/s, 1 m above the floor beside
// the pile, at `x`, into a wall 3 m ahead of it.
Scene tiled_pile_with_ball(double x) {
  Scene m = tiled_pile();
  Body wall;
  wall.id = static_cast<BodyId>(m.bodies.size());
  wall.is_static = true;
  wall.friction = 0.5;
  wall.shape = Shape::box(Vec3(0.5, 1.5, 2.0));
  wall.position = Vec3(x + 3.5, 1.5, 6.0);
  m.bodies.push_back(wall);
  Body ball;
  ball.id = wall.id + 1;
  ball.shape = Shape::sphere(0.3);
  ball.mass = 5.0;
  ball.friction = 0.5;
  ball.position = Vec3(x, 1.0, 6.0);
  ball.linear_velocity = Vec3(200.0, 0.0, 0.0);
  m.bodies.push_back(ball);
  validate_scene(m, "tiled pile with a ball", Precision::Float);
  return m;
}

const auto kMatrix = test::decomposition_matrix();

class TiledStaticsDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(TiledStaticsDecomposition, EqualsTheOneWorldHashHoldingOnlyNearbyTiles) {
  const Scene& s = tiled_pile();
  static const std::uint64_t ref = test::reference_hash(s, kSteps);
  const test::MatrixCase& c = GetParam();
  const test::MatrixRun run = test::expect_one_world_hash(s, "tiled pile 160", c, kSteps, ref);
  const WorldMetrics& t = run.total;
  const std::size_t tiles = s.static_count();
  std::printf("[ tiled pile, K %d ] %zu tiles, held %zu over the worlds, %llu held later, %llu copies\n",
              c.territories, tiles, t.statics_held, static_cast<unsigned long long>(t.statics_loaded),
              static_cast<unsigned long long>(t.static_copies));
  if (c.territories == 1) {
    EXPECT_EQ(t.statics_held, tiles);
    EXPECT_EQ(t.static_copies, 0u);
  } else {
    EXPECT_GT(t.merged_islands, 0u);
    // Fewer than every tile in every world (statics_held adds up the worlds').
    EXPECT_LT(t.statics_held, tiles * static_cast<std::size_t>(c.territories));
    EXPECT_GE(t.statics_held, tiles);  // each tile is under some world's cells
  }
}

INSTANTIATE_TEST_SUITE_P(Partitioned, TiledStaticsDecomposition, kMatrix,
                         [](const auto& info) { return test::matrix_case_name(info.param); });

// Load balancing moves cells between worlds while the pile spreads over the
// tiles: worlds rebuilt for a new map hold the tiles of their new cells.
TEST(TiledStatics, ChurnEqualsTheOneWorldHash) {
  const Scene& s = tiled_pile();
  PartitionedWorld w(s, make_partition("kmeans", s, 4, GridOptions{}), test::churn_options(3));
  w.step(kSteps);
  const BalanceTotals b = balance_totals(w.balance_log());
  const std::string reference = hash_hex(test::reference_hash(s, kSteps));
  std::printf("[ tiled pile %s, churn K 4 ] %lld cells and %lld bodies moved; %s, one world %s\n", kPrecisionName,
              static_cast<long long>(b.cells_moved), static_cast<long long>(b.bodies_moved),
              hash_hex(w.state_hash()).c_str(), reference.c_str());
  EXPECT_EQ(hash_hex(w.state_hash()), reference);
  EXPECT_GT(b.cells_moved, 0);
}

// The root of a merged island that spans a strip of 6 territories (one
// column of cells each) holds only the tiles near its own cells: the others'
// contacts with the floor are solved against copies, and the hash is the one
// world's. The floor reaches far beyond the grid's box, whose edge cells
// stand for everything beyond them.
TEST(TiledStatics, RootsSolveWithCopiesOfTilesTheyDoNotHold) {
  const Scene& s = tiled_pile();
  PartitionedOptions o;
  o.runtime.validate = true;
  PartitionedWorld w(s, make_partition("grid:6x1x1", s, 6, GridOptions{}), o);
  w.step(kSteps);
  const WorldMetrics t = test::total(w.metrics());
  std::size_t fewest = s.static_count();
  for (WorldId k = 0; k < w.world_count(); ++k) fewest = std::min(fewest, w.world(k).held_static_count());
  std::printf("[ tiled pile %s, strip of 6 ] fewest tiles a world holds %zu of %zu, %llu copies; %s\n",
              kPrecisionName, fewest, s.static_count(), static_cast<unsigned long long>(t.static_copies),
              hash_hex(w.state_hash()).c_str());
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(test::reference_hash(s, kSteps)));
  EXPECT_LT(fewest, s.static_count());
  EXPECT_GT(t.static_copies, 0u);
}

}  // namespace
}  // namespace soda

namespace soda {
namespace {

// Faster than the run's reach speed, the ball's halo reaches beyond the
// cells its world loaded at its first step (its own, dilated by the reach):
// starting 0.1 to 0.4 m before the border of a strip of 2 territories, its
// world loads the wall (and tiles) its halo reaches, so that its
// speculative contact with the wall (docs/ccd.md) is made a step before it
// would migrate, as in one world. Without the load it flies into the wall.
TEST(TiledStatics, AFastBodyLoadsTheStaticsItsHaloReaches) {
  PartitionedOptions o;
  o.runtime.validate = true;
  o.runtime.reach_speed = 1;  // reach: one cell; 2 territories are neighbours however far a halo reaches
  for (double x = -6.0; x < 6.0; x += 0.05) {
    const Scene s = tiled_pile_with_ball(x);
    const TerritoryMap map = make_partition("grid:2x1x1", s, 2, GridOptions{});
    const UniformGrid& g = map.grid();
    const Vec3 at(x, 1.0, 6.0);
    if (map.owner(g.cell_of(at)) != 0 || map.owner(g.cell_of(at + Vec3(0.1, 0, 0))) != 0 ||
        map.owner(g.cell_of(at + Vec3(0.4, 0, 0))) != 1)
      continue;
    PartitionedWorld w(s, map, o);
    w.step(kSteps);
    const WorldMetrics t = test::total(w.metrics());
    const std::string reference = hash_hex(test::reference_hash(s, kSteps));
    std::printf("[ tiled pile with a ball %s, from x %.2f ] %llu statics held later; %s, one world %s\n",
                kPrecisionName, x, static_cast<unsigned long long>(t.statics_loaded),
                hash_hex(w.state_hash()).c_str(), reference.c_str());
    EXPECT_EQ(hash_hex(w.state_hash()), reference);
    EXPECT_GT(t.statics_loaded, 0u);
    return;
  }
  FAIL() << "no start 0.1 to 0.4 m before the border";
}

}  // namespace
}  // namespace soda
