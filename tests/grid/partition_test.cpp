// make_partition: every cell owned, territories contiguous, balance,
// determinism, exact borders, bad specs.
#include <algorithm>
#include <iostream>
#include <random>
#include <tuple>

#include "grid/grid_test_util.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

using test::expect_grid_error;

std::string blocks_for(int k) {
  switch (k) {
    case 1: return "grid:1x1x1";
    case 2: return "grid:2x1x1";
    case 3: return "grid:3x1x1";
    case 4: return "grid:2x2x1";
    case 8: return "grid:2x2x2";
    default: return "grid:4x2x2";  // 16
  }
}

Scene scene_named(const std::string& name) {
  return name == "scattered" ? test::scattered_scene(800, 2024) : test::clustered_scene(800, 99);
}

// (method, k, scene)
using Case = std::tuple<std::string, int, std::string>;
class PartitionContract : public ::testing::TestWithParam<Case> {};

TEST_P(PartitionContract, OwnedConnectedAndBalanced) {
  const auto& [method, k, scene_name] = GetParam();
  const Scene scene = scene_named(scene_name);
  const std::string spec = method == "blocks" ? blocks_for(k) : method;
  const TerritoryMap map = make_partition(spec, scene, k, GridOptions{});
  ASSERT_EQ(map.world_count(), k);
  // Every box cell and every cell well outside it has an owner in 0..k-1.
  const CellBox around = map.box().grown(3);
  for (int x = around.lo.x; x <= around.hi.x; ++x)
    for (int y = around.lo.y; y <= around.hi.y; ++y)
      for (int z = around.lo.z; z <= around.hi.z; ++z) {
        const WorldId w = map.owner({x, y, z});
        ASSERT_TRUE(w >= 0 && w < k) << to_string(CellCoord{x, y, z});
      }
  for (const Vec3& far : {Vec3(1e9, -1e9, 3), Vec3(-1e12, 0, 1e12), Vec3(0, 1e300, 0)}) {
    const WorldId w = map.owner_of(far);
    EXPECT_TRUE(w >= 0 && w < k);
  }
  // Each world owns cells, forming one 6-connected piece, in and beyond the box.
  for (WorldId w = 0; w < k; ++w) {
    EXPECT_GE(map.cell_count(w), 1) << "world " << w;
    EXPECT_EQ(test::pieces_in(map, w, map.box()), 1) << "world " << w << " in the box";
    EXPECT_EQ(test::pieces_in(map, w, around), 1) << "world " << w << " around the box";
    EXPECT_EQ(territory_pieces(map, w), 1);
  }
  const PartitionStats stats = partition_stats(map, scene);
  std::int64_t total = 0;
  for (auto n : stats.bodies_per_world) total += n;
  EXPECT_EQ(total, static_cast<std::int64_t>(scene.dynamic_count()));
  std::cout << "[ stats    ] " << spec << " k=" << k << " " << scene_name
            << " imbalance(max/mean bodies)=" << stats.imbalance << " bodies:";
  for (auto n : stats.bodies_per_world) std::cout << " " << n;
  std::cout << "\n";
  // Balance where the method promises it: scattered bodies, k-means and rcb.
  if (scene_name == "scattered" && method != "blocks" && k <= 8) {
    EXPECT_LT(stats.imbalance, 1.35);
  }
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  return std::get<0>(info.param) + "_k" + std::to_string(std::get<1>(info.param)) + "_" +
         std::get<2>(info.param);
}

INSTANTIATE_TEST_SUITE_P(AllMethods, PartitionContract,
                         ::testing::Combine(::testing::Values("kmeans", "rcb", "blocks"),
                                            ::testing::Values(1, 2, 3, 4, 8, 16),
                                            ::testing::Values("scattered", "clustered")),
                         case_name);

TEST(Partition, SameInputsSameMapWhateverTheBodyOrder) {
  const Scene scene = test::clustered_scene(500, 5);
  Scene shuffled = scene;
  std::mt19937_64 rng(8);
  std::shuffle(shuffled.bodies.begin(), shuffled.bodies.end(), rng);
  for (const std::string spec : {"kmeans", "rcb", "grid:2x2x1"}) {
    const int k = 4;
    const TerritoryMap a = make_partition(spec, scene, k, GridOptions{});
    EXPECT_EQ(a, make_partition(spec, scene, k, GridOptions{})) << spec;
    EXPECT_EQ(a, make_partition(spec, shuffled, k, GridOptions{})) << spec;
  }
}

TEST(Partition, WorldIdsAreCanonical) {
  const Scene scene = test::scattered_scene(300, 4);
  for (const std::string spec : {"kmeans", "rcb"}) {
    const TerritoryMap map = make_partition(spec, scene, 6, GridOptions{});
    WorldId next = 0;
    for (WorldId w : map.owners())
      if (w == next) {
        ++next;
      } else {
        EXPECT_LT(w, next) << spec << ": ids must appear in order of first cell";
      }
    EXPECT_EQ(next, 6);
  }
}

// Grid with unit cells, origin 0, box x in [-2, 1]: grid:2x1x1 cuts at x = 0.
GridOptions border_at_zero() {
  GridOptions o;
  o.cell_size = 1.0;
  o.box = CellBox{{-2, -1, -1}, {1, 1, 1}};
  return o;
}

Scene small_scene() {
  Scene s;
  s.bodies.push_back(test::cube(1, Vec3(0.5, 0.5, 0.5), 0.25));
  s.bodies.push_back(test::cube(2, Vec3(-0.5, 0.5, 0.5), 0.25));
  return s;
}

TEST(Partition, BlockBordersLandExactlyWhereAsked) {
  const TerritoryMap two = make_partition("grid:2x1x1", small_scene(), 2, border_at_zero());
  EXPECT_EQ(two.owner_of(Vec3(-1e-9, 0.3, 0.3)), 0);
  EXPECT_EQ(two.owner_of(Vec3(+1e-9, 0.3, 0.3)), 1);
  EXPECT_EQ(two.owner_of(Vec3(0.0, 0.3, 0.3)), 1) << "a point on the border is in the upper cell";
  EXPECT_EQ(two.owner_of(Vec3(-1e-9, -1e6, 1e6)), 0) << "the border holds outside the box";
  EXPECT_EQ(two.owner_of(Vec3(+1e-9, 1e6, -1e6)), 1);
  // An offset origin moves the border with it: cells [-2,1] at origin 0.25.
  GridOptions shifted = border_at_zero();
  shifted.origin = Vec3(0.25, 0, 0);
  const TerritoryMap moved = make_partition("grid:2x1x1", small_scene(), 2, shifted);
  EXPECT_EQ(moved.owner_of(Vec3(0.25 - 1e-9, 0, 0)), 0);
  EXPECT_EQ(moved.owner_of(Vec3(0.25 + 1e-9, 0, 0)), 1);
  // grid:4x1x1 over 4 cells: borders at x = -1, 0, 1.
  const TerritoryMap four = make_partition("grid:4x1x1", small_scene(), 4, border_at_zero());
  for (int b = -1; b <= 1; ++b) {
    EXPECT_EQ(four.owner_of(Vec3(b - 1e-9, 0, 0)) + 1, four.owner_of(Vec3(b + 1e-9, 0, 0)));
  }
  // 7 cells in 3 slabs: boundaries at floor(7/3) = 2 and floor(14/3) = 4.
  GridOptions seven = border_at_zero();
  seven.box = CellBox{{0, 0, 0}, {6, 0, 0}};
  const TerritoryMap three = make_partition("grid:3x1x1", small_scene(), 3, seven);
  const std::vector<WorldId> expected{0, 0, 1, 1, 2, 2, 2};
  EXPECT_EQ(std::vector<WorldId>(three.owners().begin(), three.owners().end()), expected);
}

TEST(Partition, BlockIdsAreXMajor) {
  GridOptions o = border_at_zero();
  o.box = CellBox{{-2, -2, -2}, {1, 1, 1}};
  const TerritoryMap map = make_partition("grid:2x2x2", small_scene(), 8, o);
  EXPECT_EQ(map.owner({1, -2, 1}), (1 * 2 + 0) * 2 + 1);
  EXPECT_EQ(map.owner({-2, 1, -2}), (0 * 2 + 1) * 2 + 0);
  EXPECT_EQ(map.neighbours(0).size(), 7u);
}

TEST(Partition, ForeignCellsAcrossAPartitionBorder) {
  const TerritoryMap map = make_partition("grid:2x1x1", small_scene(), 2, border_at_zero());
  using FC = std::vector<ForeignCell>;
  EXPECT_EQ(map.foreign_cells(0, Vec3(-0.25, 0.25, 0.25), Vec3(0.25, 0.75, 1.25)),
            (FC{{{0, 0, 0}, 1}, {{0, 0, 1}, 1}}));
  EXPECT_TRUE(map.foreign_cells(1, Vec3(0.0, 0.25, 0.25), Vec3(0.5, 0.75, 0.75)).empty());
}

TEST(Partition, KLargerThanTheCellsIsRefusedAndKEqualWorks) {
  Scene one;
  one.bodies.push_back(test::cube(1, Vec3::Zero(), 0.5));  // AABB spans 2x2x2 cells
  GridOptions tight;
  tight.margin_cells = 0;
  for (const std::string spec : {"kmeans", "rcb"}) {
    const TerritoryMap map = make_partition(spec, one, 8, tight);
    for (WorldId w = 0; w < 8; ++w) EXPECT_EQ(map.cell_count(w), 1) << spec;
    expect_grid_error([&] { make_partition(spec, one, 9, tight); },
                      {"cannot make 9 contiguous territories", "8 cells", "fewer territories"});
  }
}

TEST(Partition, ScenesWithoutDynamicBodiesStillPartition) {
  Scene statics;
  Body ground = test::cube(1, Vec3::Zero(), 50.0);
  ground.is_static = true;
  statics.bodies.push_back(ground);
  GridOptions o;
  o.margin_cells = 3;
  for (const std::string spec : {"kmeans", "rcb"}) {
    const TerritoryMap map = make_partition(spec, statics, 5, o);
    for (WorldId w = 0; w < 5; ++w) EXPECT_EQ(territory_pieces(map, w), 1);
  }
}

TEST(Partition, BadSpecsAndCountsAreClearErrors) {
  const Scene s = small_scene();
  const GridOptions o = border_at_zero();
  for (const std::string spec : {"", "voronoi", "KMEANS", "/no/such/territory/file.map"})
    expect_grid_error([&] { make_partition(spec, s, 2, o); },
                      {"unknown partition spec '" + spec + "'", "kmeans", "rcb", "grid:AxBxC"});
  for (const std::string spec : {"grid:", "grid:2x2", "grid:0x1x1", "grid:2x1x1x", "grid:axbxc",
                                 "grid:2x-1x1", "grid:99999999x1x1"})
    expect_grid_error([&] { make_partition(spec, s, 2, o); }, {"bad block spec", "grid:AxBxC"});
  expect_grid_error([&] { make_partition("grid:2x2x1", s, 3, o); },
                    {"grid:2x2x1 makes 4 territories", "3"});
  expect_grid_error([&] { make_partition("grid:5x1x1", s, 5, o); },
                    {"only 4 cells along x", "5 slabs"});
  for (const std::string spec : {"kmeans", "rcb", "grid:1x1x1"})
    for (int k : {0, -3})
      expect_grid_error([&] { make_partition(spec, s, k, o); }, {"must be >= 1"});
  expect_grid_error([&] { make_partition("file:/no/such/map.txt", s, 2, o); },
                    {"cannot open territory map '/no/such/map.txt'"});
}

// A body larger than a cell spans several: any cell size is accepted.
TEST(Partition, CellsSmallerThanTheLargestBodyAreAccepted) {
  Scene s = small_scene();
  s.bodies.push_back(test::cube(3, Vec3(2, 0, 0), 1.0));  // extent 2*sqrt(3)
  GridOptions o;
  o.cell_size = 3.0;
  for (const std::string spec : {"kmeans", "rcb", "grid:1x1x1"})
    EXPECT_DOUBLE_EQ(make_partition(spec, s, 1, o).grid().cell_size(), 3.0) << spec;
}

}  // namespace
}  // namespace soda
