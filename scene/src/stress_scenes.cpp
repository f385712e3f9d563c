// Stress scenes (numerical stability) and analytic scenes (closed-form
// answers), BENCHMARKS.md and docs/scenes.md. Unlike the border scenes, two
// stress scenes break the "one cell per step" rule on purpose:
// bullet-vs-wall (200 m/s) and far-origin (float rounding far from 0).
#include <cmath>
#include <numbers>

#include "generators.h"
#include "random.h"

namespace soda::detail {

Scene start_scene(const char* name, const SceneParams& params) {
  Scene scene;
  scene.name = name;
  scene.seed = params.seed;
  return scene;
}

// ---- Stress scenes --------------------------------------------------------

Scene make_tower(const SceneParams& params) {
  Scene scene = start_scene("tower", params);
  const int k = count_or_default(params, 10, 100);
  scene.bodies.push_back(flat_ground(0.5 + kGroundMargin, 0.5));
  // Exactly resting: box i's bottom face is box i-1's top face.
  for (int i = 0; i < k; ++i)
    scene.bodies.push_back(
        dynamic_box(static_cast<BodyId>(i + 1), kUnitHalf, 1.0, Vec3(0.0, 0.5 + i, 0.0)));
  return scene;
}

Scene make_pyramid(const SceneParams& params) {
  Scene scene = start_scene("pyramid", params);
  const int base = count_or_default(params, 10, 50);
  scene.bodies.push_back(flat_ground(0.5 * base + kGroundMargin, 0.5));
  // A 2-D pyramid in the x-y plane, centred on x = 0: layer l holds base - l
  // touching unit boxes, each resting exactly on the two below it.
  BodyId id = 1;
  for (int layer = 0; layer < base; ++layer) {
    const int count = base - layer;
    for (int i = 0; i < count; ++i)
      scene.bodies.push_back(
          dynamic_box(id++, kUnitHalf, 1.0, Vec3(i - 0.5 * (count - 1), 0.5 + layer, 0.0)));
  }
  return scene;
}

Scene make_mass_ratio(const SceneParams& params) {
  Scene scene = start_scene("mass-ratio", params);
  const int ratio = magnitude_or_default(params, 100);
  scene.bodies.push_back(flat_ground(0.5 + kGroundMargin, 0.5));
  const double heavy = ratio;  // kg; the light box is 1 kg
  scene.bodies.push_back(dynamic_box(1, kUnitHalf, 1.0, Vec3(0.0, 0.5, 0.0)));
  scene.bodies.push_back(dynamic_box(2, kUnitHalf, heavy, Vec3(0.0, 1.5, 0.0)));  // on top
  return scene;
}

Scene make_bullet_vs_wall(const SceneParams& params) {
  Scene scene = start_scene("bullet-vs-wall", params);
  const int speed = magnitude_or_default(params, 200);  // m/s
  constexpr double kRadius = 0.05;
  constexpr double kWallHalfThickness = 0.05;  // 0.1 m thick, its face at x = -0.05
  // Start 10.5 m before the wall: at 200 m/s (3.33 m per step) the sphere's
  // positions straddle the wall (x = -0.5, then +2.83), so without CCD it
  // passes through; at low speeds it hits.
  constexpr double kStartX = -10.5;
  scene.bodies.push_back(flat_ground(-kStartX + kGroundMargin, 0.5));
  scene.bodies.push_back(static_box(1, Vec3(kWallHalfThickness, 2.0, 2.0), Vec3(0.0, 2.0, 0.0)));
  Body bullet = dynamic_sphere(2, kRadius, 1.0, Vec3(kStartX, 1.0, 0.0));
  bullet.linear_velocity = Vec3(speed, 0.0, 0.0);
  scene.bodies.push_back(bullet);
  return scene;
}

Scene make_far_origin(const SceneParams& params) {
  // cube-pile with 50 cubes (same seed: same pile), moved n metres along x.
  const int offset = magnitude_or_default(params, 10000);
  Scene scene = make_cube_pile({50, params.seed, false});
  scene.name = "far-origin";
  for (Body& b : scene.bodies) b.position.x() += offset;
  return scene;
}

Scene make_dense_pile(const SceneParams& params) {
  Scene scene = start_scene("dense-pile", params);
  SceneRandom rng(params.seed);
  const int n = magnitude_or_default(params, 1000);
  // Cubes of edge 0.5 m in a lattice of 6 x 6 columns, 0.6 m apart, inside a
  // bin whose inner footprint is 4 x 4 m. Each cube is tilted by at most
  // kMaxTilt about a random axis (its AABB half extent stays below 0.285 m,
  // so no two start in contact) so that the columns collapse into one pile.
  constexpr double kEdge = 0.5;
  constexpr double kSpacing = 0.6;
  constexpr int kPerRow = 6;
  constexpr double kMaxTilt = 0.1;  // rad
  constexpr double kBinHalf = 2.0;
  constexpr double kWallHalfThickness = 0.25;
  constexpr double kFirstY = 0.35;
  const int layers = (n + kPerRow * kPerRow - 1) / (kPerRow * kPerRow);
  // Walls 1 m above the highest cube, so nothing spills while falling.
  const double wall_half_height = 0.5 * (kFirstY + kSpacing * (layers - 1) + 1.0 + 0.5 * kEdge);
  const double outer = kBinHalf + 2 * kWallHalfThickness;
  scene.bodies.push_back(flat_ground(outer + kGroundMargin, 0.5));
  const double c = kBinHalf + kWallHalfThickness;
  const Vec3 along_z(kWallHalfThickness, wall_half_height, outer);
  const Vec3 along_x(outer, wall_half_height, kWallHalfThickness);
  scene.bodies.push_back(static_box(1, along_z, Vec3(c, wall_half_height, 0.0)));
  scene.bodies.push_back(static_box(2, along_z, Vec3(-c, wall_half_height, 0.0)));
  scene.bodies.push_back(static_box(3, along_x, Vec3(0.0, wall_half_height, c)));
  scene.bodies.push_back(static_box(4, along_x, Vec3(0.0, wall_half_height, -c)));
  const double offset = 0.5 * kSpacing * (kPerRow - 1);
  for (int i = 0; i < n; ++i) {
    const int layer = i / (kPerRow * kPerRow), ix = (i / kPerRow) % kPerRow, iz = i % kPerRow;
    const Vec3 p(ix * kSpacing - offset, kFirstY + layer * kSpacing, iz * kSpacing - offset);
    const double axis_y = rng.uniform(-1.0, 1.0);
    const double phi = rng.uniform(0.0, 2.0 * std::numbers::pi);
    const double r = std::sqrt(1.0 - axis_y * axis_y);
    const Vec3 axis(r * std::cos(phi), axis_y, r * std::sin(phi));
    const Quat tilt(Eigen::AngleAxisd(rng.uniform(-kMaxTilt, kMaxTilt), axis));
    scene.bodies.push_back(dynamic_box(static_cast<BodyId>(i + 5), Vec3::Constant(0.5 * kEdge),
                                       kEdge * kEdge * kEdge, p, tilt));
  }
  return scene;
}

// ---- Analytic scenes ------------------------------------------------------

Scene make_free_fall(const SceneParams& params) {
  Scene scene = start_scene("free-fall", params);
  constexpr double kHeight = 100.0;
  // 180 steps (3 s): the sphere falls 44 m and reaches 29.4 m/s, so the whole
  // run is free flight (contact would come after 4.5 s) under 30 m/s.
  // The ground is 10 m thick so that a longer run lands (at 44 m/s) without
  // tunnelling.
  scene.settings.steps = 180;
  scene.bodies.push_back(flat_ground(0.5 + kGroundMargin, 0.5, 0.0, 5.0));
  scene.bodies.push_back(dynamic_sphere(1, 0.5, 1.0, Vec3(0.0, kHeight, 0.0)));
  return scene;
}

Scene make_incline(const SceneParams& params) {
  Scene scene = start_scene("incline", params);
  constexpr double kAngle = std::numbers::pi / 6.0;  // 30 degrees
  constexpr double kBoxFriction = 0.3;    // Bullet multiplies: 0.3 * 1.0 = mu
  constexpr double kInclineFriction = 1.0;
  // The slope descends towards +x. Arc length s along it: the box starts at
  // s = 0 and slides a t^2 / 2, a = g (sin 30 - 0.3 cos 30) = 2.356 m/s^2,
  // 117.8 m in 10 s; the slope runs from s = -5 to s = 125.
  constexpr double kSlopeBegin = -5.0, kSlopeEnd = 125.0;
  const Vec3 down(std::cos(kAngle), -std::sin(kAngle), 0.0);
  const Vec3 normal(std::sin(kAngle), std::cos(kAngle), 0.0);
  const Quat tilt(Eigen::AngleAxisd(-kAngle, Vec3::UnitZ()));  // local x -> down, y -> normal
  const Vec3 box_start(0.0, 70.0, 0.0);
  const Vec3 surface_start = box_start - 0.5 * normal;
  const double half_length = 0.5 * (kSlopeEnd - kSlopeBegin);
  const Vec3 incline_centre = surface_start + 0.5 * (kSlopeBegin + kSlopeEnd) * down - 0.5 * normal;
  scene.bodies.push_back(flat_ground(70.0, 0.5, 55.0));
  Body incline = static_box(1, Vec3(half_length, 0.5, 2.0), incline_centre, tilt);
  incline.friction = kInclineFriction;
  scene.bodies.push_back(incline);
  Body box = dynamic_box(2, kUnitHalf, 1.0, box_start, tilt);
  box.friction = kBoxFriction;
  scene.bodies.push_back(box);
  return scene;
}

Scene make_resting_stack(const SceneParams& params) {
  Scene scene = start_scene("resting-stack", params);
  scene.bodies.push_back(flat_ground(0.5 + kGroundMargin, 0.5));
  for (int i = 0; i < 3; ++i)
    scene.bodies.push_back(
        dynamic_box(static_cast<BodyId>(i + 1), kUnitHalf, 1.0, Vec3(0.0, 0.5 + i, 0.0)));
  return scene;
}

Scene make_rolling_sphere(const SceneParams& params) {
  Scene scene = start_scene("rolling-sphere", params);
  constexpr double kRadius = 0.5;
  constexpr double kSpeed = 2.0;  // m/s along +x; from x = -10 to +10 in 10 s
  scene.bodies.push_back(flat_ground(10.0 + kGroundMargin, 0.5));
  Body ball = dynamic_sphere(1, kRadius, 1.0, Vec3(-10.0, kRadius, 0.0));
  ball.linear_velocity = Vec3(kSpeed, 0.0, 0.0);
  // Rolling without slipping: the contact point's velocity v + w x (-r y) is 0.
  ball.angular_velocity = Vec3(0.0, 0.0, -kSpeed / kRadius);
  scene.bodies.push_back(ball);
  return scene;
}

}  // namespace soda::detail
