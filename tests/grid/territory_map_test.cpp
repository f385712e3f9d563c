// TerritoryMap: ownership of all of Z^3, neighbours, the foreign-cells query.
#include <algorithm>
#include <utility>

#include "grid/grid_test_util.h"
#include "soda/grid/territory_map.h"

namespace soda {
namespace {

using test::expect_grid_error;

// Two slabs split at x = 0: cells x in [-2, -1] -> world 0, x in [0, 1] -> 1.
TerritoryMap two_slabs() {
  const CellBox box{{-2, -1, -1}, {1, 1, 1}};
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()));
  for (std::size_t i = 0; i < owners.size(); ++i) owners[i] = box.cell_at(i).x < 0 ? 0 : 1;
  return TerritoryMap(UniformGrid(Vec3::Zero(), 1.0), box, std::move(owners), 2);
}

TEST(TerritoryMap, EveryCellOfZ3HasTheNearestBoxCellsOwner) {
  const TerritoryMap map = two_slabs();
  EXPECT_EQ(map.owner({-2, 0, 0}), 0);
  EXPECT_EQ(map.owner({1, 0, 0}), 1);
  EXPECT_EQ(map.owner({-1000, 50, -70}), 0);
  EXPECT_EQ(map.owner({1000, -50, 70}), 1);
  EXPECT_EQ(map.owner({-1, 99999, 0}), 0);
  EXPECT_EQ(map.owner({0, -99999, 0}), 1);
  EXPECT_EQ(map.owner({kMaxCellIndex, kMaxCellIndex, -kMaxCellIndex}), 1);
  EXPECT_EQ(map.owner_of(Vec3(-1e-9, 1e15, 3.0)), 0);
  EXPECT_EQ(map.owner_of(Vec3(1e-9, -1e15, 3.0)), 1);
  EXPECT_EQ(map.owner_of(Vec3(-1e300, 0, 0)), 0);
  // Far cells form no new adjacency: territories stay connected beyond the box.
  const CellBox far = map.box().grown(4);
  for (WorldId w = 0; w < 2; ++w) EXPECT_EQ(test::pieces_in(map, w, far), 1);
}

TEST(TerritoryMap, DefaultIsOneWorldEverywhere) {
  const TerritoryMap map;
  EXPECT_EQ(map.world_count(), 1);
  EXPECT_EQ(map.owner({123, -4, 5}), 0);
  EXPECT_TRUE(map.neighbours(0).empty());
}

TEST(TerritoryMap, ConstructorRejectsBadInput) {
  const UniformGrid g;
  const CellBox box{{0, 0, 0}, {1, 0, 0}};
  expect_grid_error([&] { TerritoryMap(g, box, {0}, 1); }, {"1 owners", "2 cells"});
  expect_grid_error([&] { TerritoryMap(g, box, {0, 2}, 2); }, {"owner 2", "outside 0..1"});
  expect_grid_error([&] { TerritoryMap(g, box, {0, 0}, 0); }, {"at least one world"});
  expect_grid_error([&] { TerritoryMap(g, CellBox{{0, 0, 0}, {-1, 0, 0}}, {}, 1); }, {"empty"});
}

TEST(TerritoryMap, CellsCountsAndNeighbours) {
  const TerritoryMap map = two_slabs();
  EXPECT_EQ(map.world_count(), 2);
  EXPECT_EQ(map.cell_count(0), 18);
  EXPECT_EQ(map.cells_of(1).size(), 18u);
  EXPECT_EQ(map.cells_of(1).front(), (CellCoord{0, -1, -1}));
  EXPECT_EQ(map.neighbours(0), std::vector<WorldId>{1});
  EXPECT_EQ(map.neighbours(1), std::vector<WorldId>{0});
  expect_grid_error([&] { map.cells_of(2); }, {"world id 2"});
  expect_grid_error([&] { map.neighbours(-1); }, {"world id -1"});
}

TEST(TerritoryMap, CornerAndEdgeContactsMakeNeighbours) {
  // 2x2x2 box: world 1 owns (0,0,0), world 2 owns (1,1,1) (corner contact
  // only with world 1), world 3 owns (1,1,0) (edge contact with world 1).
  const CellBox box{{0, 0, 0}, {1, 1, 1}};
  std::vector<WorldId> owners(8, 0);
  owners[box.index({0, 0, 0})] = 1;
  owners[box.index({1, 1, 1})] = 2;
  owners[box.index({1, 1, 0})] = 3;
  const TerritoryMap map(UniformGrid(), box, owners, 4);
  EXPECT_EQ(map.neighbours(1), (std::vector<WorldId>{0, 2, 3}));
  EXPECT_EQ(map.neighbours(2), (std::vector<WorldId>{0, 1, 3}));
  EXPECT_EQ(map.neighbours(0), (std::vector<WorldId>{1, 2, 3}));
  for (WorldId a = 0; a < 4; ++a)
    for (WorldId b : map.neighbours(a)) {
      const auto& back = map.neighbours(b);
      EXPECT_NE(std::find(back.begin(), back.end(), a), back.end()) << "not symmetric";
    }
}

TEST(TerritoryMap, ForeignCellsOfAnAabbStraddlingTheBorder) {
  const TerritoryMap map = two_slabs();
  using FC = std::vector<ForeignCell>;
  const Vec3 lo(-0.3, 0.1, 0.1);
  const Vec3 hi(0.2, 0.4, 0.4);
  EXPECT_EQ(map.foreign_cells(0, lo, hi), (FC{{{0, 0, 0}, 1}}));
  EXPECT_EQ(map.foreign_cells(1, lo, hi), (FC{{{-1, 0, 0}, 0}}));
  // Across a y boundary too: two foreign cells, canonical order.
  EXPECT_EQ(map.foreign_cells(0, Vec3(-0.3, -0.2, 0.1), Vec3(0.2, 0.4, 0.2)),
            (FC{{{0, -1, 0}, 1}, {{0, 0, 0}, 1}}));
  // Inside one's own territory: nothing foreign.
  EXPECT_TRUE(map.foreign_cells(0, Vec3(-1.9, 0.1, 0.1), Vec3(-1.1, 0.9, 0.9)).empty());
  EXPECT_EQ(map.foreign_cells(1, Vec3(-1.9, 0.1, 0.1), Vec3(-1.1, 0.9, 0.9)),
            (FC{{{-2, 0, 0}, 0}}));
  // Far outside the box the border still holds (clamped owners).
  EXPECT_EQ(map.foreign_cells(0, Vec3(-0.5, 500.2, -900.7), Vec3(0.5, 500.4, -900.6)),
            (FC{{{0, 500, -901}, 1}}));
  expect_grid_error([&] { map.foreign_cells(0, hi, lo); }, {"exceeds"});
  expect_grid_error([&] { map.foreign_cells(0, Vec3(-1e5, -1e5, 0), Vec3(1e5, 1e5, 0)); },
                    {"more than the limit"});
}

TEST(TerritoryMap, CopiesAreEqualAndReassignedLeavesTheOriginal) {
  const TerritoryMap map = two_slabs();
  const TerritoryMap copy = map;  // NOLINT(performance-unnecessary-copy-initialization)
  EXPECT_EQ(copy, map);
  EXPECT_EQ(copy.owners().data(), map.owners().data()) << "copies share storage";
  const std::pair<CellCoord, WorldId> change{{0, 0, 0}, 0};
  const TerritoryMap moved = map.reassigned(std::span(&change, 1));
  EXPECT_EQ(map.owner({0, 0, 0}), 1);
  EXPECT_EQ(moved.owner({0, 0, 0}), 0);
  EXPECT_EQ(moved.cell_count(0), 19);
  EXPECT_FALSE(moved == map);
  const std::pair<CellCoord, WorldId> outside{{9, 0, 0}, 0};
  expect_grid_error([&] { map.reassigned(std::span(&outside, 1)); }, {"outside the map box"});
}

}  // namespace
}  // namespace soda

namespace soda {
namespace {

// Brute force: worlds owning a box cell within `reach` (Chebyshev) of a box
// cell of w.
std::vector<WorldId> neighbours_by_brute_force(const TerritoryMap& map, WorldId w, int reach) {
  std::set<WorldId> out;
  const CellBox& box = map.box();
  for (std::size_t i = 0; i < static_cast<std::size_t>(box.count()); ++i) {
    const CellCoord a = box.cell_at(i);
    if (map.owner(a) != w) continue;
    for (std::size_t j = 0; j < static_cast<std::size_t>(box.count()); ++j) {
      const CellCoord b = box.cell_at(j);
      const int d = std::max({std::abs(a.x - b.x), std::abs(a.y - b.y), std::abs(a.z - b.z)});
      if (d <= reach && map.owner(b) != w) out.insert(map.owner(b));
    }
  }
  return {out.begin(), out.end()};
}

TEST(TerritoryMap, WithReachWidensNeighboursToCellsWithinReach) {
  // Random owners (scattered, non-contiguous territories: the worst case for
  // the dilation) and a strip of one-cell slabs.
  std::mt19937_64 rng(7);
  const CellBox box{{-3, -1, 0}, {4, 2, 5}};
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()));
  for (WorldId& o : owners) o = static_cast<WorldId>(rng() % 9);
  const TerritoryMap random(UniformGrid(Vec3::Zero(), 1.0), box, owners, 10);  // world 9 owns nothing
  const CellBox strip_box{{0, 0, 0}, {7, 0, 0}};
  std::vector<WorldId> strip_owners = {0, 1, 2, 3, 4, 5, 6, 7};
  const TerritoryMap strip(UniformGrid(Vec3::Zero(), 0.5), strip_box, strip_owners, 8);
  for (const TerritoryMap* base : {&random, &strip})
    for (int reach : {1, 2, 3, 5}) {
      const TerritoryMap map = base->with_reach(reach);
      EXPECT_EQ(map.reach(), reach);
      for (WorldId w = 0; w < map.world_count(); ++w)
        EXPECT_EQ(map.neighbours(w), neighbours_by_brute_force(map, w, reach)) << "world " << w << " reach " << reach;
    }
  EXPECT_EQ(strip.with_reach(2).neighbours(3), (std::vector<WorldId>{1, 2, 4, 5}));
  EXPECT_EQ(strip.with_reach(1), strip);
  EXPECT_FALSE(strip.with_reach(2) == strip);
  EXPECT_EQ(strip.with_reach(2).reassigned({}).reach(), 2);
  expect_grid_error([&] { (void)strip.with_reach(0); }, {"reach 0"});
  expect_grid_error([&] { (void)strip.with_reach(kMaxReachCells + 1); }, {"reach"});
}

}  // namespace
}  // namespace soda
