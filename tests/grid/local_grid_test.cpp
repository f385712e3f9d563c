// LocalGrid: own cells, a one-cell margin carrying owners, nothing beyond.
#include <algorithm>

#include "grid/grid_test_util.h"
#include "soda/grid/local_grid.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

bool adjacent_to_own(const TerritoryMap& map, WorldId w, const CellCoord& c) {
  const int r = map.reach();  // within the map's reach (1: 26-adjacent)
  for (int dx = -r; dx <= r; ++dx)
    for (int dy = -r; dy <= r; ++dy)
      for (int dz = -r; dz <= r; ++dz)
        if (map.owner({c.x + dx, c.y + dy, c.z + dz}) == w) return true;
  return false;
}

// Invariants 1-3 of local_grid.h, checked over the map box grown by 3.
void check_local_grids(const TerritoryMap& map) {
  const CellBox region = map.box().grown(3);
  for (WorldId w = 0; w < map.world_count(); ++w) {
    const LocalGrid local(map, w);
    EXPECT_EQ(local.neighbours(), map.neighbours(w));
    EXPECT_EQ(local.own_cells(), map.cells_of(w));
    for (int x = region.lo.x; x <= region.hi.x; ++x)
      for (int y = region.lo.y; y <= region.hi.y; ++y)
        for (int z = region.lo.z; z <= region.hi.z; ++z) {
          const CellCoord c{x, y, z};
          const WorldId got = local.owner(c);
          if (adjacent_to_own(map, w, c))
            ASSERT_EQ(got, map.owner(c)) << "world " << w << " cell " << to_string(c);
          else
            ASSERT_TRUE(got == kNoWorld || got == map.owner(c));
          ASSERT_EQ(local.owns(c), map.owner(c) == w);
        }
    for (const ForeignCell& m : local.margin_cells()) {
      EXPECT_NE(m.owner, w);
      EXPECT_EQ(m.owner, map.owner(m.cell));
      EXPECT_TRUE(adjacent_to_own(map, w, m.cell));
    }
  }
}

TEST(LocalGrid, ThreeSlabsMiddleWorldSeesBothNeighbours) {
  const CellBox box{{0, 0, 0}, {5, 1, 1}};
  GridOptions o;
  o.cell_size = 1.0;
  o.box = box;
  Scene s;
  s.bodies.push_back(test::cube(1, Vec3(0.5, 0.5, 0.5), 0.25));
  const TerritoryMap map = make_partition("grid:3x1x1", s, 3, o);
  const LocalGrid mid(map, 1);  // owns x in [2, 3]
  EXPECT_EQ(mid.neighbours(), (std::vector<WorldId>{0, 2}));
  EXPECT_EQ(mid.box(), (CellBox{{1, 0, 0}, {4, 1, 1}}));
  EXPECT_EQ(mid.owner({1, 0, 0}), 0);
  EXPECT_EQ(mid.owner({4, 1, 1}), 2);
  EXPECT_EQ(mid.owner({0, 0, 0}), kNoWorld) << "two cells away is not known";
  EXPECT_EQ(mid.owner({5, 0, 0}), kNoWorld);
  EXPECT_EQ(mid.owner({3, 40, -7}), 1) << "own cells continue outside the map box";
  EXPECT_EQ(mid.owner({4, 40, -7}), 2) << "so does the margin";
  EXPECT_TRUE(mid.is_margin({1, 1, 1}));
  EXPECT_FALSE(mid.is_margin({2, 1, 1}));
  EXPECT_EQ(mid.margin_cells().size(), 8u);
  EXPECT_EQ(mid.own_cells().size(), 8u);
  using FC = std::vector<ForeignCell>;
  EXPECT_EQ(mid.foreign_cells(Vec3(3.8, 0.2, 0.2), Vec3(4.1, 0.4, 0.4)), (FC{{{4, 0, 0}, 2}}));
  EXPECT_EQ(mid.foreign_cells(Vec3(3.8, 0.2, 0.2), Vec3(5.1, 0.4, 0.4)),
            (FC{{{4, 0, 0}, 2}, {{5, 0, 0}, kNoWorld}}));
  check_local_grids(map);
  test::expect_grid_error([&] { LocalGrid(map, 3); }, {"world id 3"});
}

TEST(LocalGrid, MatchesTheMapForKMeansTerritories) {
  const Scene s = test::clustered_scene(300, 7);
  check_local_grids(make_partition("kmeans", s, 8, GridOptions{}));
}

TEST(LocalGrid, MarginFollowsTheMapsReach) {
  const Scene s = test::clustered_scene(300, 7);
  check_local_grids(make_partition("kmeans", s, 8, GridOptions{}).with_reach(2));
}

TEST(LocalGrid, SingleWorldHasNoMargin) {
  const Scene s = test::scattered_scene(20, 3);
  const TerritoryMap map = make_partition("rcb", s, 1, GridOptions{});
  const LocalGrid only(map, 0);
  EXPECT_TRUE(only.neighbours().empty());
  EXPECT_TRUE(only.margin_cells().empty());
  EXPECT_EQ(only.owner({1 << 20, 0, 0}), 0);
}

}  // namespace
}  // namespace soda
