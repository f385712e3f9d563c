// Collision filtering (Body::collision_group, collision_mask;
// docs/scene-format.md, "Collision filtering") keeps decomposition
// invariance: a pile whose boxes fall in three groups, each masking out the
// next one, so that about a third of the touching pairs pass through each
// other, ends with the one-world hash for K = 1, 2, 4, 8 territories,
// speculating (anticipation 8), under SyncTest and with parking on and off.
// The filter decides: the same pile unfiltered ends elsewhere, and so does a
// pile whose filter reaches only the worlds that own the bodies (a ghost
// without it would touch what its owner does not).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "runtime/partitioned_test_util.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"

namespace soda {
namespace {

constexpr int kSteps = 200;

// Dynamic body i: group bit 1 + i % 3, every mask bit but the next group's:
// a and b touch unless a % 3 and b % 3 are next to each other (mod 3).
// Statics keep the default filter: everything lands on the ground.
Scene filtered(Scene s) {
  for (Body& b : s.bodies) {
    if (b.is_static) continue;
    b.collision_group = 2u << (b.id % 3);
    b.collision_mask = ~(2u << ((b.id + 1) % 3));
  }
  return s;
}

const Scene& pile() {
  static const Scene s = filtered(test::scene("cube-pile", 150));
  return s;
}

std::uint64_t reference(bool parking) { return test::reference_hash(pile(), kSteps, parking); }

class FilterDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(FilterDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  static const std::uint64_t ref = reference(false);
  const test::MatrixRun run = test::expect_one_world_hash(pile(), "filtered cube-pile 150", c, kSteps, ref);
  const WorldMetrics& t = run.total;
  if (c.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);
    EXPECT_GT(t.migrations_out, 0u);
  }
  if (c.territories >= 8) EXPECT_GT(t.merged_islands, 0u);  // kmeans on 2 and 4 cuts no filtered island
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, FilterDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

// The one world with parking on gives the same hash as with it off; the
// filter changes the result (the pile unfiltered ends elsewhere).
TEST(FilterDecomposition, ParkingDoesNotMatterAndTheFilterDoes) {
  const std::uint64_t off = reference(false), on = reference(true);
  CanonicalWorld plain(test::scene("cube-pile", 150));
  for (int i = 0; i < kSteps; ++i) plain.step();
  std::printf("[ filtered cube-pile 150 %s ] one world: parking off %s, on %s; unfiltered %s\n", kPrecisionName,
              hash_hex(off).c_str(), hash_hex(on).c_str(), hash_hex(plain.state_hash()).c_str());
  EXPECT_EQ(hash_hex(on), hash_hex(off));
  EXPECT_NE(hash_hex(plain.state_hash()), hash_hex(off));
}

// Two boxes dropped one onto the other: with filters that keep them apart
// the upper one falls through the lower one to the ground, in the one world,
// in two territories split between them and in stock Bullet; with the
// default filter it rests on top.
Scene two_boxes(bool apart) {
  Scene s;
  s.name = "two-boxes";
  Body ground;
  ground.id = 0;
  ground.is_static = true;
  ground.shape = Shape::box(Vec3(10, 0.5, 10));
  ground.position = Vec3(0, -0.5, 0);
  s.bodies.push_back(ground);
  for (BodyId id : {BodyId{1}, BodyId{2}}) {
    Body b;
    b.id = id;
    b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
    b.position = Vec3(0.3, id == 1 ? 0.5 : 1.6, 0.0);
    if (apart) {
      b.collision_group = id == 1 ? 2u : 4u;
      b.collision_mask = id == 1 ? ~4u : ~2u;
    }
    s.bodies.push_back(b);
  }
  return s;
}

double upper_height(const std::vector<BodyState>& states) {
  for (const BodyState& b : states)
    if (b.id == 2) return double(b.origin[1]);
  return -1e9;
}

TEST(FilterDecomposition, FilteredBoxesPassThroughEachOtherEverywhere) {
  for (bool apart : {false, true}) {
    const Scene s = two_boxes(apart);
    CanonicalWorld one(s);
    StockWorld stock(s);
    GridOptions g;
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    const TerritoryMap map = make_partition("grid:2x1x1", s, 2, g);
    PartitionedWorld two(s, map);
    for (int i = 0; i < 120; ++i) one.step(), stock.step();
    two.step(120);
    const double y1 = upper_height(one.body_states()), y2 = upper_height(two.body_states()),
                 ys = upper_height(stock.body_states());
    std::printf("[ two boxes %s, %s ] upper box at y %.3f (one world), %.3f (K 2), %.3f (stock)\n", kPrecisionName,
                apart ? "filtered apart" : "default filter", y1, y2, ys);
    EXPECT_EQ(hash_hex(two.state_hash()), hash_hex(one.state_hash()));
    for (double y : {y1, y2, ys}) {
      if (apart) {
        EXPECT_NEAR(y, 0.5, 0.05);  // on the ground, inside the lower box
      } else {
        EXPECT_NEAR(y, 1.5, 0.05);  // on the lower box
      }
    }
  }
}

}  // namespace
}  // namespace soda
