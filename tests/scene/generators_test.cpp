// Scene generators: deterministic from the seed, and as BENCHMARKS.md defines them.
#include <cmath>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

TEST(Generators, SameSeedSameSceneOtherSeedOtherScene) {
  const std::string a = scene_to_json(make_scene("falling-cubes", {300, 5, false}));
  EXPECT_EQ(a, scene_to_json(make_scene("falling-cubes", {300, 5, false})));
  EXPECT_NE(a, scene_to_json(make_scene("falling-cubes", {300, 6, false})));
}

TEST(Generators, FallingCubesMatchesDefinition) {
  const int n = 400;
  const Scene s = make_scene("falling-cubes", {n, 3, false});
  EXPECT_EQ(s.dynamic_count(), static_cast<std::size_t>(n));
  EXPECT_EQ(s.static_count(), 1u);
  const double half = std::sqrt(static_cast<double>(n));  // L / 2
  std::set<BodyId> ids;
  for (const Body& b : s.bodies) {
    EXPECT_TRUE(ids.insert(b.id).second);
    if (b.is_static) {
      EXPECT_DOUBLE_EQ(b.position.y() + b.shape.half_extents.y(), 0.0);  // top at y = 0
      EXPECT_GT(b.shape.half_extents.x(), half);
      continue;
    }
    EXPECT_EQ(b.mass, 1.0);
    EXPECT_EQ(b.shape.half_extents, Vec3::Constant(0.5));
    EXPECT_EQ(b.friction, 0.5);
    EXPECT_EQ(b.restitution, 0.0);
    EXPECT_LE(std::abs(b.position.x()), half);
    EXPECT_LE(std::abs(b.position.z()), half);
    EXPECT_GE(b.position.y(), 1.0);
    EXPECT_LE(b.position.y(), 21.0);
  }
  // Non-overlapping bounding spheres.
  const double min_d = std::sqrt(3.0);
  for (std::size_t i = 1; i < s.bodies.size(); ++i)
    for (std::size_t j = i + 1; j < s.bodies.size(); ++j)
      ASSERT_GE((s.bodies[i].position - s.bodies[j].position).norm(), min_d) << i << " " << j;
}

TEST(Generators, RandomScaleEdgesInRange) {
  const Scene s = make_scene("falling-cubes", {300, 9, true});
  double lo = 10, hi = 0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    const double edge = 2 * b.shape.half_extents.x();
    lo = std::min(lo, edge);
    hi = std::max(hi, edge);
    EXPECT_NEAR(b.mass, edge * edge * edge, 1e-12);
  }
  EXPECT_GE(lo, 0.2);
  EXPECT_LT(hi, 1.3);
  EXPECT_LT(lo, 0.3);  // the range is actually used
  EXPECT_GT(hi, 1.2);
}

TEST(Generators, CubePileMatchesDefinition) {
  const int n = 250;  // side = ceil(sqrt(25)) = 5 columns per axis, 10 layers
  const Scene s = make_scene("cube-pile", {n, 1, false});
  EXPECT_EQ(s.dynamic_count(), static_cast<std::size_t>(n));
  std::set<double> xs, ys;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    xs.insert(b.position.x());
    ys.insert(b.position.y());
  }
  EXPECT_EQ(xs.size(), 5u);
  EXPECT_EQ(ys.size(), 10u);
  EXPECT_DOUBLE_EQ(*xs.begin(), -3.0);  // centred: -3, -1.5, 0, 1.5, 3
  EXPECT_DOUBLE_EQ(*xs.rbegin(), 3.0);
  EXPECT_DOUBLE_EQ(*ys.begin(), 2.0);
  EXPECT_DOUBLE_EQ(*ys.rbegin(), 2.0 + 9 * 1.5);
}

TEST(Generators, UnknownSceneNamesTheKnownOnes) {
  try {
    make_scene("falling-cubs", {});
    FAIL();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("falling-cubes"), std::string::npos) << e.what();
  }
}

TEST(Generators, NegativeCountIsRejected) { EXPECT_THROW(make_scene("cube-pile", {-1, 1, false}), SceneError); }

TEST(Generators, LargestExtentIsBoundingDiameter) {
  const Scene s = make_scene("falling-cubes", {50, 1, false});
  EXPECT_NEAR(s.largest_dynamic_extent(), std::sqrt(3.0), 1e-12);
}

// alternating-load (docs/scenes.md): mirror-image halves, nothing near x = 0,
// only vertical launches, a column per 3 cubes with one wake box each.
TEST(Generators, AlternatingLoadMatchesDefinition) {
  const std::string a = scene_to_json(make_scene("alternating-load", {600, 2, false}));
  EXPECT_EQ(a, scene_to_json(make_scene("alternating-load", {600, 2, false})));
  EXPECT_NE(a, scene_to_json(make_scene("alternating-load", {600, 3, false})));

  const Scene s = make_scene("alternating-load", {601, 1, false});  // rounded up to 102 columns of 3
  const std::size_t columns = 2 * 101;
  ASSERT_EQ(s.static_count(), 1u);
  ASSERT_EQ(s.dynamic_count(), columns * 4);  // 3 cubes and a wake box per column
  EXPECT_NEAR(s.largest_dynamic_extent(), std::sqrt(3.0), 1e-12);
  for (std::size_t i = 0; i < s.bodies.size(); ++i) EXPECT_EQ(s.bodies[i].id, i);  // ground 0, then 1..N
  std::multiset<std::tuple<double, double, double>> left, right;
  for (const Body& b : s.bodies) {
    if (b.is_static) {
      EXPECT_DOUBLE_EQ(b.position.y() + b.shape.half_extents.y(), 0.0);  // ground top at y = 0
      continue;
    }
    EXPECT_GE(std::abs(b.position.x()), 9.0) << "body " << b.id;  // the gap around the cut at x = 0
    EXPECT_EQ(b.linear_velocity.x(), 0.0);
    EXPECT_EQ(b.linear_velocity.z(), 0.0);
    EXPECT_EQ(b.angular_velocity, Vec3::Zero());
    (b.position.x() < 0 ? left : right).insert({std::abs(b.position.x()), b.position.y(), b.position.z()});
  }
  EXPECT_EQ(left, right);  // mirror images in x
}

TEST(Generators, AlternatingLoadDefaultSize) {
  const Scene s = make_scene("alternating-load", {0, 1, false});
  EXPECT_EQ(s.dynamic_count(), 3200u);  // 2400 cubes and 800 wake boxes
}

}  // namespace
}  // namespace soda
