// UniformGrid, cells and boxes, make_grid / make_box.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <unordered_set>

#include "grid/grid_test_util.h"
#include "soda/grid/grid.h"

namespace soda {
namespace {

using test::cube;
using test::expect_grid_error;

TEST(CellCoord, OrderIsLexicographicAndHashWorks) {
  EXPECT_LT((CellCoord{0, 5, 5}), (CellCoord{1, 0, 0}));
  EXPECT_LT((CellCoord{1, 0, 9}), (CellCoord{1, 1, 0}));
  EXPECT_LT((CellCoord{1, 1, -1}), (CellCoord{1, 1, 0}));
  EXPECT_EQ((CellCoord{1, 2, 3}), (CellCoord{1, 2, 3}));
  std::unordered_set<CellCoord, CellCoordHash> set;
  for (int x = -3; x <= 3; ++x)
    for (int y = -3; y <= 3; ++y)
      for (int z = -3; z <= 3; ++z) set.insert({x, y, z});
  EXPECT_EQ(set.size(), 343u);
  EXPECT_TRUE(set.count({-3, 2, 1}));
  EXPECT_EQ(std::hash<CellCoord>{}({1, 2, 3}), CellCoordHash{}({1, 2, 3}));
}

TEST(CellBox, IndexRoundTripsInCanonicalOrder) {
  const CellBox box{{-2, 0, 3}, {1, 2, 4}};
  EXPECT_EQ(box.count(), 4 * 3 * 2);
  CellCoord previous{-100, 0, 0};
  for (std::size_t i = 0; i < static_cast<std::size_t>(box.count()); ++i) {
    const CellCoord c = box.cell_at(i);
    EXPECT_TRUE(box.contains(c));
    EXPECT_EQ(box.index(c), i);
    EXPECT_LT(previous, c) << "index order must be the canonical cell order";
    previous = c;
  }
  EXPECT_EQ(box.clamp({-50, 1, 100}), (CellCoord{-2, 1, 4}));
  EXPECT_EQ(box.grown(1).count(), 6 * 5 * 4);
  EXPECT_FALSE((CellBox{{0, 0, 0}, {-1, 0, 0}}).valid());
  EXPECT_EQ((CellBox{{0, 0, 0}, {-1, 0, 0}}).count(), 0);
}

TEST(UniformGrid, CellOfFloorsAndBoundariesGoUp) {
  const UniformGrid g(Vec3(0.5, -1.0, 0.0), 2.0);
  EXPECT_EQ(g.cell_of(Vec3(0.5, -1.0, 0.0)), (CellCoord{0, 0, 0}));
  EXPECT_EQ(g.cell_of(Vec3(2.4999, 0.9999, 1.9999)), (CellCoord{0, 0, 0}));
  EXPECT_EQ(g.cell_of(Vec3(2.5, 1.0, 2.0)), (CellCoord{1, 1, 1}));  // boundary -> upper cell
  EXPECT_EQ(g.cell_of(Vec3(0.4999, -1.0001, -1e-12)), (CellCoord{-1, -1, -1}));
  EXPECT_EQ(g.cell_of(Vec3(-5.5, -7.0, -4.0)), (CellCoord{-3, -3, -2}));
  EXPECT_EQ(g.cell_min({1, -2, 3}), Vec3(2.5, -5.0, 6.0));
  EXPECT_EQ(g.cell_max({1, -2, 3}), Vec3(4.5, -3.0, 8.0));
  EXPECT_EQ(g.cell_center({0, 0, 0}), Vec3(1.5, 0.0, 1.0));
  for (const CellCoord c : {CellCoord{0, 0, 0}, CellCoord{-4, 7, 2}})
    EXPECT_EQ(g.cell_of(g.cell_center(c)), c);
}

TEST(UniformGrid, FarPositionsSaturateAndNonFiniteIsAnError) {
  const UniformGrid g(Vec3::Zero(), 1.0);
  EXPECT_EQ(g.cell_of(Vec3(1e30, -1e30, 0.5)), (CellCoord{kMaxCellIndex, -kMaxCellIndex, 0}));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expect_grid_error([&] { g.cell_of(Vec3(nan, 0, 0)); }, {"not finite"});
  expect_grid_error([&] { g.cell_of(Vec3(0, inf, 0)); }, {"not finite"});
  expect_grid_error([] { UniformGrid(Vec3::Zero(), 0.0); }, {"cell size", "> 0"});
  expect_grid_error([] { UniformGrid(Vec3::Zero(), -1.0); }, {"cell size"});
}

// cell_of floors without libm (grid.h); these pin it to the definition,
// std::clamp(std::floor((p - origin) / cell_size), +-kMaxCellIndex), at the
// inputs where a hand-written floor goes wrong.
int reference_cell(double p, double origin, double cell_size) {
  constexpr double kLimit = kMaxCellIndex;
  return static_cast<int>(std::clamp(std::floor((p - origin) / cell_size), -kLimit, kLimit));
}

TEST(UniformGrid, CellOfEdgeCasesOnAUnitGrid) {
  // On unit cells at the origin, (p - 0) / 1 == p exactly: cell_of is floor.
  const UniformGrid g(Vec3::Zero(), 1.0);
  auto cell = [&](double v) { return g.cell_of(Vec3(v, 0.0, 0.0)).x; };
  const double up = std::numeric_limits<double>::infinity();
  const double denorm = std::numeric_limits<double>::denorm_min();
  const double max = std::numeric_limits<double>::max();
  const double limit = kMaxCellIndex;  // 2^29
  // Exact integers, both signs, and zero of both signs.
  for (int i : {0, 1, 2, 3, 7, 1000, -1, -2, -3, -7, -1000}) EXPECT_EQ(cell(i), i) << i;
  EXPECT_EQ(cell(0.0), 0);
  EXPECT_EQ(cell(-0.0), 0);
  // Just below and just above integers: negatives round down, not toward 0.
  EXPECT_EQ(cell(std::nextafter(3.0, -up)), 2);
  EXPECT_EQ(cell(std::nextafter(3.0, up)), 3);
  EXPECT_EQ(cell(std::nextafter(-3.0, up)), -3);
  EXPECT_EQ(cell(std::nextafter(-3.0, -up)), -4);
  EXPECT_EQ(cell(std::nextafter(1.0, -up)), 0);
  EXPECT_EQ(cell(std::nextafter(-1.0, up)), -1);
  EXPECT_EQ(cell(-0.5), -1);
  EXPECT_EQ(cell(0.5), 0);
  EXPECT_EQ(cell(-1e-300), -1);
  EXPECT_EQ(cell(-denorm), -1);
  EXPECT_EQ(cell(denorm), 0);
  // Around the saturation limit 2^29 and beyond (exact integers up to 2^53,
  // where every double is an integer, and the largest finite double).
  EXPECT_EQ(cell(limit - 1.0), kMaxCellIndex - 1);
  EXPECT_EQ(cell(std::nextafter(limit, -up)), kMaxCellIndex - 1);
  EXPECT_EQ(cell(limit), kMaxCellIndex);
  EXPECT_EQ(cell(limit + 0.5), kMaxCellIndex);
  EXPECT_EQ(cell(-limit + 0.5), -kMaxCellIndex);
  EXPECT_EQ(cell(std::nextafter(-limit, up)), -kMaxCellIndex);
  EXPECT_EQ(cell(-limit), -kMaxCellIndex);
  EXPECT_EQ(cell(-limit - 0.5), -kMaxCellIndex);
  for (double v : {0x1p31, 0x1p31 + 1.0, 0x1p32, 0x1p52 + 1.0, 0x1p53, 0x1p63, 0x1p64, 1e300, max}) {
    EXPECT_EQ(cell(v), kMaxCellIndex) << v;
    EXPECT_EQ(cell(-v), -kMaxCellIndex) << -v;
  }
  // (p - origin) overflowing to infinity still saturates.
  const UniformGrid far(Vec3(-max, max, 0.0), 1.0);
  EXPECT_EQ(far.cell_of(Vec3(max, -max, 0.0)), (CellCoord{kMaxCellIndex, -kMaxCellIndex, 0}));
}

TEST(UniformGrid, CellOfMatchesTheLibmDefinitionEverywhere) {
  std::mt19937_64 rng(7);
  auto unit = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  const double up = std::numeric_limits<double>::infinity();
  long checked = 0;
  for (double cell_size : {1.0, 0.1, 1.7320508075688772, 3.0, 1e-3, 1e6, 0.7}) {
    for (double o : {0.0, -0.0, 0.5, -1.25, 1e-9, -123.456, 1e5}) {
      const UniformGrid g(Vec3(o, o, o), cell_size);
      auto check = [&](double v) {
        const CellCoord c = g.cell_of(Vec3(v, -v, v * 0.5));
        ASSERT_EQ(c.x, reference_cell(v, o, cell_size)) << v << " origin " << o << " cell " << cell_size;
        ASSERT_EQ(c.y, reference_cell(-v, o, cell_size)) << -v << " origin " << o << " cell " << cell_size;
        ASSERT_EQ(c.z, reference_cell(v * 0.5, o, cell_size)) << v * 0.5 << " origin " << o << " cell " << cell_size;
        ++checked;
      };
      // Cell boundaries origin + k * cell_size and their neighbouring doubles.
      for (int k = -50; k <= 50; ++k) {
        const double b = o + k * cell_size;
        check(b);
        check(std::nextafter(b, up));
        check(std::nextafter(b, -up));
      }
      // Random magnitudes from 1e-12 to 1e12 cells, both signs.
      for (int i = 0; i < 2000; ++i) check(std::ldexp(unit() - 0.5, static_cast<int>(rng() % 80) - 40) * cell_size);
      // Around the saturation limit.
      for (double t : {-0x1p29 - 1.0, -0x1p29, -0x1p29 + 1.0, 0x1p29 - 1.0, 0x1p29, 0x1p29 + 1.0}) {
        check(o + t * cell_size);
        check(std::nextafter(o + t * cell_size, up));
        check(std::nextafter(o + t * cell_size, -up));
      }
    }
  }
  EXPECT_GT(checked, 100000);
}

TEST(UniformGrid, CellsOverlappingAnAabb) {
  const UniformGrid g(Vec3::Zero(), 1.0);
  EXPECT_EQ(g.cells_overlapping(Vec3(0.2, 0.2, 0.2), Vec3(0.8, 0.8, 0.8)),
            (CellBox{{0, 0, 0}, {0, 0, 0}}));
  EXPECT_EQ(g.cells_overlapping(Vec3(-0.1, 0.5, 1.5), Vec3(1.2, 0.6, 2.5)),
            (CellBox{{-1, 0, 1}, {1, 0, 2}}));
  // Touching a boundary from below counts (conservative).
  EXPECT_EQ(g.cells_overlapping(Vec3(0.5, 0.5, 0.5), Vec3(1.0, 0.5, 0.5)),
            (CellBox{{0, 0, 0}, {1, 0, 0}}));
  expect_grid_error([&] { g.cells_overlapping(Vec3(1, 0, 0), Vec3(0, 1, 1)); }, {"exceeds"});
}

// A few large bodies among many small ones do not size the cells: 90 % of
// the bodies fit the default cell.
TEST(MakeGrid, DefaultCellSizeFitsNinetyPercentOfTheBodies) {
  Scene s;
  for (BodyId id = 1; id <= 90; ++id) s.bodies.push_back(cube(id, Vec3(2.0 * id, 0, 0), 0.5));
  for (BodyId id = 91; id <= 100; ++id) s.bodies.push_back(cube(id, Vec3(0, 25.0 * id, 0), 10.0));  // 20 m boxes
  EXPECT_DOUBLE_EQ(default_cell_size(s), std::sqrt(3.0));  // 10 of 100 are large
  EXPECT_DOUBLE_EQ(make_grid(s, GridOptions{}).cell_size(), std::sqrt(3.0));
  s.bodies.push_back(cube(101, Vec3(0, -50, 0), 10.0));  // 11 of 101 (10.9 %)
  EXPECT_DOUBLE_EQ(default_cell_size(s), 20.0 * std::sqrt(3.0));
}

TEST(MakeGrid, CellSizeIsTheLargestDynamicExtentByDefault) {
  Scene s;
  s.bodies.push_back(cube(1, Vec3::Zero(), 0.5));
  s.bodies.push_back(cube(2, Vec3(3, 0, 0), 1.0));
  Body ground = cube(3, Vec3(0, -50, 0), 40.0);  // statics do not size cells
  ground.is_static = true;
  s.bodies.push_back(ground);
  const UniformGrid g = make_grid(s, GridOptions{});
  EXPECT_DOUBLE_EQ(g.cell_size(), s.largest_dynamic_extent());
  EXPECT_DOUBLE_EQ(g.cell_size(), 2.0 * std::sqrt(3.0));
  EXPECT_EQ(g.origin(), Vec3::Zero());
  EXPECT_DOUBLE_EQ(make_grid(Scene{}, GridOptions{}).cell_size(), kDefaultCellSize);
}

TEST(MakeGrid, AnyPositiveOverrideIsAccepted) {
  Scene s;
  s.bodies.push_back(cube(1, Vec3::Zero(), 0.5));  // extent sqrt(3) = 1.732...
  GridOptions o;
  o.cell_size = 1.0;  // smaller than the body: it spans several cells
  EXPECT_DOUBLE_EQ(make_grid(s, o).cell_size(), 1.0);
  o.cell_size = 5.0;
  EXPECT_DOUBLE_EQ(make_grid(s, o).cell_size(), 5.0);
  o.cell_size = -2.0;
  expect_grid_error([&] { make_grid(s, o); }, {"finite and > 0"});
}

TEST(MakeBox, SceneBoundsPlusMargin) {
  Scene s;
  s.bodies.push_back(cube(1, Vec3(0.5, 0.5, 0.5), 0.25));
  s.bodies.push_back(cube(2, Vec3(4.5, 2.5, 0.5), 0.25));
  GridOptions o;
  o.cell_size = 1.0;
  const UniformGrid g = make_grid(s, o);
  EXPECT_EQ(make_box(s, g, o), (CellBox{{-1, -1, -1}, {5, 3, 1}}));
  o.margin_cells = 0;
  EXPECT_EQ(make_box(s, g, o), (CellBox{{0, 0, 0}, {4, 2, 0}}));
  o.box = CellBox{{-3, 0, 0}, {2, 0, 0}};
  EXPECT_EQ(make_box(s, g, o), *o.box);
  o.box = CellBox{{0, 0, 0}, {-1, 0, 0}};
  expect_grid_error([&] { make_box(s, g, o); }, {"explicit grid box", "empty"});
  o.box.reset();
  o.margin_cells = -1;
  expect_grid_error([&] { make_box(s, g, o); }, {"margin"});
  o.margin_cells = 1;
  s.bodies.push_back(cube(3, Vec3(4000, 4000, 4000), 0.25));  // tiny cells, wide scene
  o.cell_size = s.largest_dynamic_extent();
  expect_grid_error([&] { make_box(s, make_grid(s, o), o); }, {"more than the limit", "larger cell size"});
}

}  // namespace
}  // namespace soda
