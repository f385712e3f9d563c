// Border scenes (scene registry, docs/scenes.md) on grids whose borders lie
// exactly where the contacts are (origin 0, 2 m cells: borders at x = 0 and
// z = 0): a tower on a border, a tower on a four-territory corner, boxes
// sliding across borders, a fast sphere crossing territories and a chain
// whose one island spans every territory of a 1x8 strip. Each must match the
// one-world run bit for bit and show the mechanism it exists for.
#include "runtime/partitioned_test_util.h"

namespace soda {
namespace {

using test::border_grid;

struct Outcome {
  std::uint64_t reference = 0, partitioned = 0;
  WorldMetrics total;
};

Outcome run(const std::string& name, int n, const std::string& partition, int k, const GridOptions& grid, int steps) {
  const Scene s = test::scene(name, n);
  const TerritoryMap map = make_partition(partition, s, k, grid);
  PartitionedWorld world(s, map, PartitionedOptions{.runtime = {.validate = true}});
  world.step(steps);
  Outcome o{test::reference_hash(s, steps), world.state_hash(), test::total(world.metrics())};
  std::printf("[ %s %s %s K=%d ] %d steps: one world %s, partitioned %s; %s\n", name.c_str(), kPrecisionName,
              partition.c_str(), k, steps, hash_hex(o.reference).c_str(), hash_hex(o.partitioned).c_str(),
              test::summary(o.total).c_str());
  if (o.reference != o.partitioned) ADD_FAILURE() << test::first_divergence(s, map, steps);
  return o;
}

TEST(BorderScenes, TowersOnABorder) {
  // grid:2x1x1 cuts at x = 0: both towers of seam-stack stand on the border.
  const Outcome o = run("seam-stack", 0, "grid:2x1x1", 2, border_grid(), 300);
  EXPECT_EQ(hash_hex(o.partitioned), hash_hex(o.reference));
  EXPECT_GT(o.total.merged_islands, 0u);
  EXPECT_EQ(o.total.merged_island_worlds_max, 2u);
  EXPECT_GT(o.total.manifolds_seeded, 0u);
}

TEST(BorderScenes, TowerOnAFourTerritoryCorner) {
  // grid:2x1x2 cuts at x = 0 and z = 0: the second tower stands on the corner.
  const Outcome o = run("seam-stack", 0, "grid:2x1x2", 4, border_grid(), 300);
  EXPECT_EQ(hash_hex(o.partitioned), hash_hex(o.reference));
  EXPECT_EQ(o.total.merged_island_worlds_max, 4u);
  EXPECT_GT(o.total.manifolds_seeded, 0u);
}

TEST(BorderScenes, BoxesSlidingAcrossBorders) {
  const Outcome o = run("cross-traffic", 0, "grid:2x1x2", 4, border_grid(), 240);
  EXPECT_EQ(hash_hex(o.partitioned), hash_hex(o.reference));
  EXPECT_GT(o.total.migrations_out, 4u);
  EXPECT_GT(o.total.merged_islands, 0u);
  EXPECT_GT(o.total.manifolds_seeded, 0u);
}

TEST(BorderScenes, FastSphereCrossingTerritories) {
  // It leaves the corner x = z = 0 at 20 m/s (1/3 m per step), hits a box,
  // bounces off the walls: with 2 m cells it crosses borders often.
  // Migrations (measured): 8 on the grid, 2 with k-means since the
  // canonical world's two fixed friction directions (#17; 3 before).
  struct Case {
    std::string partition;
    int k;
    std::size_t migrations;
  };
  for (const Case& c : {Case{"grid:4x1x4", 16, 3}, Case{"kmeans", 8, 2}}) {
    const std::string& partition = c.partition;
    const Outcome o = run("projectile", 0, partition, c.k, border_grid(), 400);
    EXPECT_EQ(hash_hex(o.partitioned), hash_hex(o.reference));
    EXPECT_GE(o.total.migrations_out, c.migrations) << partition;
    EXPECT_GT(o.total.ghosts_sent, 0u) << partition;
  }
}

TEST(BorderScenes, ChainSpanningEveryTerritoryOfAStrip) {
  // 16 unit boxes on x in [-8, 8]: a box of 8 cells along x, one per world.
  GridOptions g = border_grid();
  g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  const Outcome o = run("chain", 16, "grid:8x1x1", 8, g, 200);
  EXPECT_EQ(hash_hex(o.partitioned), hash_hex(o.reference));
  EXPECT_EQ(o.total.merged_island_worlds_max, 8u) << "the chain's island must span all 8 worlds";
  EXPECT_GT(o.total.fragments_relayed, 0u) << "fragments must be relayed hop by hop";
  EXPECT_GT(o.total.ghosts_sent, 0u);
}

TEST(BorderScenes, TheRootIsTheWorldWithTheLargestShare) {
  // The chain's cells x in [-8, 4) cut in two at x = -2: world 0 owns boxes
  // 1-6 (the smallest id), world 1 boxes 7-16. The world whose fragments
  // weigh most (bodies + manifolds) solves the island, not the owner of its
  // smallest body; the bits are the one world's either way.
  GridOptions g = border_grid();
  g.box = CellBox{{-4, 0, -1}, {1, 0, 0}};
  const Scene s = test::scene("chain", 16);
  const TerritoryMap map = make_partition("grid:2x1x1", s, 2, g);
  PartitionedWorld world(s, map, PartitionedOptions{.runtime = {.validate = true}});
  world.step(120);
  const std::uint64_t reference = test::reference_hash(s, 120);
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(reference));
  const std::vector<WorldMetrics> m = world.metrics();
  ASSERT_EQ(m.size(), 2u);
  std::printf("[ chain %s root ] owned %zu / %zu, islands solved %llu / %llu, merged %llu\n", kPrecisionName,
              static_cast<std::size_t>(m[0].owned_bodies), static_cast<std::size_t>(m[1].owned_bodies),
              static_cast<unsigned long long>(m[0].islands_solved),
              static_cast<unsigned long long>(m[1].islands_solved),
              static_cast<unsigned long long>(m[1].merged_islands));
  EXPECT_EQ(m[0].owned_bodies, 6u);
  EXPECT_EQ(m[1].owned_bodies, 10u);
  EXPECT_GT(m[1].merged_islands, 0u);
  EXPECT_EQ(m[1].islands_solved, m[1].merged_islands);
  EXPECT_EQ(m[0].islands_solved, 0u);
}

}  // namespace
}  // namespace soda
