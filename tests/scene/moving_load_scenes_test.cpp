// Load-balance scenes (docs/scenes.md): hotspot, avalanche, rain — as
// defined, seeded, valid, and rain's inputs consistent with its scene.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string_view>

#include <gtest/gtest.h>

#include "soda/scene/input_file.h"
#include "soda/scene/registry.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

// Smallest distance between the centres of two dynamic bodies in the x-z
// plane among those selected.
template <typename Pred>
double closest_xz(const Scene& s, Pred selected) {
  double best = 1e300;
  for (std::size_t i = 0; i < s.bodies.size(); ++i)
    for (std::size_t j = i + 1; j < s.bodies.size(); ++j) {
      const Body &a = s.bodies[i], &b = s.bodies[j];
      if (a.is_static || b.is_static || !selected(a) || !selected(b)) continue;
      best = std::min(best, std::hypot(a.position.x() - b.position.x(), a.position.z() - b.position.z()));
    }
  return best;
}

TEST(LoadScenes, SeededAndValid) {
  for (const char* name : {"hotspot", "avalanche", "rain", "drift"}) {
    const std::string a = scene_to_json(make_scene(name, {64, 2, false}));
    EXPECT_EQ(a, scene_to_json(make_scene(name, {64, 2, false}))) << name;
    const bool seeded = std::string_view(name) != "avalanche";  // avalanche draws nothing from the seed
    if (seeded) {
      EXPECT_NE(a, scene_to_json(make_scene(name, {64, 3, false}))) << name;
    }
    for (int n : {1, 64, 400}) {
      const Scene s = make_scene(name, {n, 1, false});
      EXPECT_NO_THROW(validate_scene(s, name, Precision::Float)) << name << " n " << n;
      for (std::size_t i = 0; i < s.bodies.size(); ++i) EXPECT_EQ(s.bodies[i].id, i) << name;
    }
    EXPECT_THROW(make_scene(name, {20001, 1, false}), SceneError) << name;
  }
}

TEST(LoadScenes, HotspotMatchesDefinition) {
  const Scene s = make_scene("hotspot", {64, 1, false});
  ASSERT_EQ(s.static_count(), 2u);         // ground, wall
  ASSERT_EQ(s.dynamic_count(), 64u + 8u);  // 8 x 8 block, a catch of 8
  const double wall_face = s.bodies[1].position.x() - 0.5;
  EXPECT_DOUBLE_EQ(wall_face, 30.0);       // three block lengths of 10 m
  int moving = 0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    EXPECT_DOUBLE_EQ(b.position.y(), 0.5);  // resting on the ground
    if (b.linear_velocity.x() != 0) {
      ++moving;
      EXPECT_EQ(b.linear_velocity, Vec3(8.0, 0.0, 0.0));
      EXPECT_GE(b.position.x(), 0.0);
      EXPECT_LE(b.position.x(), 10.0);
    } else {
      EXPECT_NEAR(b.position.x(), wall_face - 0.501, 1e-12);  // the catch
    }
  }
  EXPECT_EQ(moving, 64);
  EXPECT_GE(closest_xz(s, [](const Body&) { return true; }), 1.25 - 1e-12);
  // Low friction: the block reaches the catch at 4 m/s: v0^2 - 2 mu g d = 16.
  const double mu = s.bodies[0].friction, d = (wall_face - 1.001) - (9.375 + 0.5);
  EXPECT_NEAR(64.0 - 2.0 * mu * 9.81 * d, 16.0, 1e-9);
  EXPECT_GT(s.settings.steps, 300);
}

TEST(LoadScenes, DriftMatchesDefinition) {
  const Scene s = make_scene("drift", {64, 1, false});
  ASSERT_EQ(s.static_count(), 1u);         // the ground
  ASSERT_EQ(s.dynamic_count(), 64u + 2u);  // 8 x 8 block, two markers
  int moving = 0;
  double marker_x = 0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    EXPECT_DOUBLE_EQ(b.position.y(), 0.5);
    if (b.linear_velocity.x() != 0) {
      ++moving;
      EXPECT_EQ(b.linear_velocity, Vec3(8.0, 0.0, 0.0));
      EXPECT_GE(b.position.x(), 0.0);
      EXPECT_LE(b.position.x(), 10.0);
    } else {
      marker_x = b.position.x();
      EXPECT_DOUBLE_EQ(std::abs(b.position.z()), 4.375);  // the side lanes
    }
  }
  EXPECT_EQ(moving, 64);
  EXPECT_DOUBLE_EQ(marker_x, 31.5);  // 3 block lengths + 2 m, less half a cube
  // Friction alone stops the front faces at 3 L - 1 = 29 m: v0^2 = 2 mu g d.
  const double mu = s.bodies[0].friction, d = 29.0 - (9.375 + 0.5);
  EXPECT_NEAR(64.0, 2.0 * mu * 9.81 * d, 1e-9);
  EXPECT_GT(s.settings.steps, 8.0 / (mu * 9.81) * 60.0);  // at rest before the end
}

TEST(LoadScenes, AvalancheMatchesDefinition) {
  const Scene s = make_scene("avalanche", {64, 1, false});
  ASSERT_EQ(s.static_count(), 3u);  // ground, slope, wall
  ASSERT_EQ(s.dynamic_count(), 64u + 8u);
  const Body& slope = s.bodies[1];
  const Vec3 normal = slope.orientation * Vec3::UnitY();
  EXPECT_NEAR(std::acos(normal.y()), std::numbers::pi / 6, 1e-12);  // 30 degrees
  const Vec3 top_point = slope.position + 0.5 * normal;               // on the slope's surface
  int on_slope = 0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    EXPECT_EQ(b.linear_velocity, Vec3::Zero());
    EXPECT_DOUBLE_EQ(b.friction, 0.4);
    if (b.position.x() < 0) {
      ++on_slope;
      EXPECT_NEAR((b.position - top_point).dot(normal), 0.501, 1e-9);  // resting 1 mm above it
    } else {
      EXPECT_DOUBLE_EQ(b.position.y(), 0.5);  // the fence, on the run-out
    }
  }
  EXPECT_EQ(on_slope, 64);
  EXPECT_GT(std::tan(std::numbers::pi / 6), 0.4);  // it slides from rest
}

TEST(LoadScenes, RainWavesAreTheSceneAndItsInputs) {
  const int n = 100;
  const Scene s = make_scene("rain", {n, 4, false});
  const std::vector<UserInput> inputs = scene_inputs("rain", {n, 4, false});
  ASSERT_FALSE(inputs.empty());
  // Waves of ceil(100 / 16) = 7 until 100 are in: 15 waves (the last of 2),
  // 7 cubes in the scene, 93 inputs, the last wave at step 14 x 30.
  EXPECT_EQ(inputs.size(), 93u);
  std::size_t falling = 0;
  for (const Body& b : s.bodies)
    if (!b.is_static && b.linear_velocity.y() < 0) ++falling;
  EXPECT_EQ(falling, 7u);
  BodyId next = static_cast<BodyId>(s.bodies.size());
  std::int64_t last_step = 0;
  const double side = s.bodies[2].position.x() - 0.25;  // the bin's +x wall's inner face
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const UserInput& in = inputs[i];
    EXPECT_EQ(in.kind, UserInput::Kind::AddBody);
    EXPECT_EQ(in.sequence, i);
    EXPECT_EQ(in.body.id, next++);  // ids continue the scene's, in order
    EXPECT_EQ(in.step % 30, 0);
    EXPECT_GE(in.step, last_step);
    last_step = in.step;
    EXPECT_NO_THROW(validate_body(in.body, "rain input"));
    EXPECT_GT(in.body.position.x(), 0.5);
    EXPECT_LT(in.body.position.x(), side - 0.5);
    EXPECT_EQ(in.body.linear_velocity, Vec3(0.0, -3.0, 0.0));
  }
  EXPECT_EQ(last_step, 420);
  // Inside a wave, cubes are at least a lattice pitch less the jitter apart.
  for (std::int64_t step = 30; step <= 420; step += 30) {
    Scene wave;
    for (const UserInput& in : inputs)
      if (in.step == step) wave.bodies.push_back(in.body);
    EXPECT_GE(closest_xz(wave, [](const Body&) { return true; }), 1.8) << "wave at " << step;
  }
  // Written and read back bit-exact, as `soda run --inputs` would read them.
  const std::vector<UserInput> back = parse_inputs_json(inputs_to_json(inputs), "rain.json");
  ASSERT_EQ(back.size(), inputs.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].body.position, inputs[i].body.position);
    EXPECT_EQ(back[i].step, inputs[i].step);
  }
  EXPECT_TRUE(scene_inputs("falling-cubes", {n, 4, false}).empty());
  EXPECT_TRUE(scene_inputs("no-such-scene", {n, 4, false}).empty());
}

}  // namespace
}  // namespace soda
