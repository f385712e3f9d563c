// Triangles within each cell's reach (soda/grid/cell_triangles.h) and the
// partitions that weigh bodies by them: a region of dense level geometry is
// cut into more, smaller territories than one of coarse geometry holding as
// many bodies; without the weight both get the same.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numeric>
#include <random>

#include "soda/grid/cell_triangles.h"
#include "soda/grid/kmeans.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

std::shared_ptr<const HeightfieldData> flat_heightfield(int columns, int rows, double spacing) {
  auto hf = std::make_shared<HeightfieldData>();
  hf->columns = columns;
  hf->rows = rows;
  hf->heights.assign(static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows), 0.0);
  hf->spacing = Vec3(spacing, 1.0, spacing);
  return hf;
}

Body static_body(BodyId id, Shape shape, const Vec3& position) {
  Body b;
  b.id = id;
  b.is_static = true;
  b.mass = 0;
  b.shape = std::move(shape);
  b.position = position;
  return b;
}

// One quad (two triangles) spanning x, z in [0, 1] at y = 0.25, on unit
// cells: each triangle's box grown by half a cell is [-0.5, 1.5] x [-0.25,
// 0.75] x [-0.5, 1.5], which overlaps cells x, z in {-1, 0, 1} and y in
// {-1, 0}: 18 cells hold 2 triangles each, the others none.
TEST(CellTriangles, CountsTheTrianglesWithinEachCellsReach) {
  const UniformGrid grid(Vec3::Zero(), 1.0);
  const CellBox box{{-3, -3, -3}, {3, 3, 3}};
  auto mesh = std::make_shared<TriangleMeshData>();
  mesh->vertices = {Vec3(-0.5, 0, -0.5), Vec3(0.5, 0, -0.5), Vec3(-0.5, 0, 0.5), Vec3(0.5, 0, 0.5)};
  mesh->triangles = {{{0, 2, 1}}, {{1, 2, 3}}};
  for (const Shape& shape : {Shape::heightfield_of(flat_heightfield(2, 2, 1.0)), Shape::triangle_mesh(mesh)}) {
    const std::vector<Body> bodies{static_body(0, shape, Vec3(0.5, 0.25, 0.5))};
    ASSERT_TRUE(has_level_geometry(bodies));
    const std::vector<std::int32_t> counts = cell_triangles(bodies, grid, box);
    ASSERT_EQ(counts.size(), static_cast<std::size_t>(box.count()));
    for (std::size_t i = 0; i < counts.size(); ++i) {
      const CellCoord c = box.cell_at(i);
      const bool reached = c.x >= -1 && c.x <= 1 && c.z >= -1 && c.z <= 1 && c.y >= -1 && c.y <= 0;
      EXPECT_EQ(counts[i], reached ? 2 : 0) << shape_kind_name(shape.kind) << " cell " << c.x << ", " << c.y << ", "
                                            << c.z;
    }
  }
}

TEST(CellTriangles, ABodysTurnAndBoxCountAndOtherShapesDoNot) {
  const UniformGrid grid(Vec3::Zero(), 1.0);
  const CellBox box{{-3, -3, -3}, {3, 3, 3}};
  // Turned a quarter about x, the quad stands in the plane z = 0.5 (x and y
  // from 0 to 1): grown by half a cell, it reaches z from 0 to 1.
  Body turned = static_body(0, Shape::heightfield_of(flat_heightfield(2, 2, 1.0)), Vec3(0.5, 0.5, 0.5));
  turned.orientation = Quat(Eigen::AngleAxisd(EIGEN_PI / 2, Vec3::UnitX()));
  const std::vector<std::int32_t> counts = cell_triangles({turned}, grid, box);
  EXPECT_EQ(counts[box.index({0, 0, 0})], 2);
  EXPECT_EQ(counts[box.index({0, 0, 1})], 2);
  EXPECT_EQ(counts[box.index({0, 0, 2})], 0);
  EXPECT_EQ(counts[box.index({0, -2, 0})], 0);
  // Outside the box: nothing counts, nothing is clamped in.
  const Body far = static_body(0, Shape::heightfield_of(flat_heightfield(2, 2, 1.0)), Vec3(50, 0, 0));
  const std::vector<std::int32_t> none = cell_triangles({far}, grid, box);
  EXPECT_EQ(std::accumulate(none.begin(), none.end(), std::int64_t{0}), 0);
  // A box ground is no level geometry.
  const std::vector<Body> ground{static_body(0, Shape::box(Vec3(10, 0.5, 10)), Vec3::Zero())};
  EXPECT_FALSE(has_level_geometry(ground));
  const std::vector<std::int32_t> zero = cell_triangles(ground, grid, box);
  EXPECT_EQ(std::accumulate(zero.begin(), zero.end(), std::int64_t{0}), 0);
}

// 200 unit spheres in one layer over a ground of two flat heightfields side
// by side: x < 0 sampled every 0.125 m (51,200 triangles), x > 0 every 2 m
// (200). Each half holds 100 bodies.
Scene two_grounds() {
  Scene s;
  s.name = "two-grounds";
  s.bodies.push_back(static_body(0, Shape::heightfield_of(flat_heightfield(161, 161, 0.125)), Vec3(-10, 0, 0)));
  s.bodies.push_back(static_body(1, Shape::heightfield_of(flat_heightfield(11, 11, 2.0)), Vec3(10, 0, 0)));
  BodyId id = 2;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 10; ++j) {
      Body b;
      b.id = id++;
      b.shape = Shape::sphere(0.5);
      b.position = Vec3(-19.0 + 2.0 * i, 0.6, -9.0 + 2.0 * j);
      s.bodies.push_back(b);
    }
  return s;
}

struct Sides {
  int dense_worlds = 0, coarse_worlds = 0;  // worlds whose bodies lie mostly at x < 0, x > 0
  double dense_cells = 0, coarse_cells = 0;  // mean cells of those worlds
};

Sides sides(const TerritoryMap& map, const Scene& scene) {
  std::vector<double> x_sum(static_cast<std::size_t>(map.world_count()), 0.0);
  std::vector<int> n(x_sum.size(), 0);
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    const auto w = static_cast<std::size_t>(map.owner_of(b.position));
    x_sum[w] += b.position.x();
    ++n[w];
  }
  Sides s;
  for (std::size_t w = 0; w < x_sum.size(); ++w) {
    if (n[w] == 0) continue;
    const double cells = static_cast<double>(map.cell_count(static_cast<WorldId>(w)));
    if (x_sum[w] < 0) {
      ++s.dense_worlds;
      s.dense_cells += cells;
    } else {
      ++s.coarse_worlds;
      s.coarse_cells += cells;
    }
  }
  if (s.dense_worlds > 0) s.dense_cells /= s.dense_worlds;
  if (s.coarse_worlds > 0) s.coarse_cells /= s.coarse_worlds;
  return s;
}

class HeavyTriangleRegion : public ::testing::TestWithParam<const char*> {};

TEST_P(HeavyTriangleRegion, GetsMoreAndSmallerTerritories) {
  const Scene scene = two_grounds();
  GridOptions weighed;  // the documented weight
  GridOptions bodies_only;
  bodies_only.triangle_weight = 0;
  const TerritoryMap with = make_partition(GetParam(), scene, 4, weighed);
  const TerritoryMap without = make_partition(GetParam(), scene, 4, bodies_only);
  const Sides a = sides(with, scene), b = sides(without, scene);
  std::printf("[ two grounds, %s K 4 ] with triangles: %d dense-side worlds of %.0f cells, %d coarse of %.0f; "
              "bodies only: %d of %.0f, %d of %.0f\n",
              GetParam(), a.dense_worlds, a.dense_cells, a.coarse_worlds, a.coarse_cells, b.dense_worlds,
              b.dense_cells, b.coarse_worlds, b.coarse_cells);
  EXPECT_EQ(b.dense_worlds, 2);
  EXPECT_EQ(b.coarse_worlds, 2);
  EXPECT_GE(a.dense_worlds, 3);
  EXPECT_LT(a.dense_cells, a.coarse_cells);
  // The weight each world holds evens out with the triangles counted, not
  // without them.
  const PartitionStats sa = partition_stats(with, scene), sb = partition_stats(without, scene);
  std::printf("[ two grounds, %s K 4 ] max / mean weight: %.3f with triangles, %.3f bodies only\n", GetParam(),
              sa.weighted_imbalance, sb.weighted_imbalance);
  EXPECT_LT(sa.weighted_imbalance, 1.5);
  EXPECT_GT(sb.weighted_imbalance, 1.5);
}

INSTANTIATE_TEST_SUITE_P(Partitions, HeavyTriangleRegion, ::testing::Values("kmeans", "rcb"));

// The weights keep the partition a pure function of the scene: the same
// map whatever the order of the bodies.
TEST(HeavyTriangleRegion, MapDoesNotDependOnBodyOrder) {
  const Scene scene = two_grounds();
  Scene shuffled = scene;
  std::mt19937_64 rng(7);
  std::shuffle(shuffled.bodies.begin(), shuffled.bodies.end(), rng);
  for (const char* spec : {"kmeans", "rcb"}) {
    const TerritoryMap a = make_partition(spec, scene, 4, GridOptions{});
    const TerritoryMap b = make_partition(spec, shuffled, 4, GridOptions{});
    EXPECT_TRUE(std::equal(a.owners().begin(), a.owners().end(), b.owners().begin(), b.owners().end())) << spec;
  }
}

TEST(HeavyTriangleRegion, RejectsABadWeight) {
  const Scene scene = two_grounds();
  for (double w : {-1.0, std::nan("")}) {
    GridOptions o;
    o.triangle_weight = w;
    EXPECT_THROW(make_partition("rcb", scene, 2, o), GridError);
  }
}

TEST(EqualWeightKMeans, EqualWeightsAreTheEqualSizeClustering) {
  std::mt19937_64 rng(3);
  std::vector<Vec3> points;
  for (int i = 0; i < 301; ++i)
    points.emplace_back(static_cast<double>(rng() % 1000) / 10.0, static_cast<double>(rng() % 1000) / 10.0, 0.0);
  const std::vector<std::int64_t> ones(points.size(), 7);
  const KMeansResult a = equal_size_kmeans(points, 5, 1, 50);
  const KMeansResult b = equal_size_kmeans(points, ones, 5, 1, 50);
  EXPECT_EQ(a.labels, b.labels);
}

TEST(EqualWeightKMeans, NoClusterExceedsItsShareByTheLargestWeight) {
  std::mt19937_64 rng(5);
  std::vector<Vec3> points;
  std::vector<std::int64_t> weights;
  for (int i = 0; i < 400; ++i) {
    const double x = static_cast<double>(rng() % 1000) / 10.0;
    points.emplace_back(x, static_cast<double>(rng() % 1000) / 10.0, 0.0);
    weights.push_back(x < 50 ? 20 : 1);  // the left half 20 times as heavy
  }
  const int k = 4;
  const KMeansResult r = equal_size_kmeans(points, weights, k, 1, 50);
  const std::int64_t total = std::accumulate(weights.begin(), weights.end(), std::int64_t{0});
  const std::int64_t cap = (total + k - 1) / k;
  std::vector<std::int64_t> load(k, 0);
  for (std::size_t i = 0; i < points.size(); ++i) load[static_cast<std::size_t>(r.labels[i])] += weights[i];
  for (int c = 0; c < k; ++c) EXPECT_LT(load[static_cast<std::size_t>(c)], cap + 20) << "cluster " << c;
  EXPECT_THROW(equal_size_kmeans(points, std::vector<std::int64_t>(points.size(), 0), k, 1, 50), GridError);
  EXPECT_THROW(equal_size_kmeans(points, std::vector<std::int64_t>(3, 1), k, 1, 50), GridError);
}

}  // namespace
}  // namespace soda
