// Load scenes (BENCHMARKS.md, docs/scenes.md): scenes whose cost moves
// between regions over time.
//
// alternating-load — the load alternates between the halves x < 0 and x > 0
// in windows of kWindowSteps steps, and nothing ever comes near x = 0, so
// that with two territories cut at x = 0 each world's neighbour never sends
// it a ghost or a migrant (speculation's bets hold) while the two worlds'
// step costs alternate (what speculation can overlap). Invariants:
//  1. every dynamic body starts with a vertical velocity above the axis of
//     its column and only lands on its column (or the ground under it):
//     nothing comes nearer x = 0 than about 8 m (over four cells of the
//     unit cube's 1.73 m on each side of the cut);
//  2. the halves are mirror images in their initial positions (only the
//     launch speeds and the seeded yaws differ), all at the same heights,
//     so equal-size k-means with k = 2 cuts at x = 0;
//  3. window j = 0, 1, 2, 3 begins at step kFirstLanding + j * kWindowSteps
//     and belongs to the left half for even j: in window 0 the left columns
//     land, in 1 the right ones, in 2 a wake box lands on every left column,
//     in 3 on every right one. A column that lands or is hit settles and
//     falls asleep within its window; in between it costs next to nothing.
#include <cmath>
#include <numbers>
#include <vector>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultLoadCubes = 2400;
// A column: kLayers unit cubes (1 kg), seeded random yaw, launched together
// kLayerPitch apart, so they land one onto another. Taller columns topple
// and take longer to come to rest.
constexpr int kLayers = 3;
constexpr double kLayerPitch = 1.5;
// Columns kColumnPitch apart: at least 0.58 m between neighbours at any yaw
// (a yawed unit cube reaches 0.71 m from its axis), so each column is its
// own island that falls asleep on its own.
constexpr double kColumnPitch = 2.0;
constexpr int kSpotSide = 8;            // a landing spot: up to 8 x 8 columns, 16 m square
constexpr double kSpotGap = 6.0;        // m between neighbouring spots
constexpr double kHalfGap = 8.0;        // m from x = 0 to the nearest spot (its columns' axes: 9 m)
// The wake box, one per column, lands on the column's top face at the
// column's second window. Light (0.05 kg, 400 kg/m^3), so that the hit, at
// up to 37 m/s, wakes the column without toppling it: with 0.5 kg a few
// percent of the columns kept moving past their window.
constexpr double kWakeEdge = 0.5;
constexpr double kWakeMass = 0.05;
constexpr double kWakeStartAbove = 1.0; // m between a column's top face and its wake box at the start
// 150 steps (2.5 s) per window: a column that lands or is hit falls asleep
// about 135 steps later (measured; Bullet puts a body to sleep after 2 s
// below its sleeping thresholds), so the windows do not overlap.
constexpr int kWindowSteps = 150;
constexpr int kFirstLanding = 10;       // step at which the left columns land (window 0)

// Vertical launch speed that brings a body from height y0 to y1 in k steps
// of Bullet's semi-implicit Euler (v += g dt, then y += v dt):
// y_k = y0 + k dt v0 - g dt^2 k (k + 1) / 2, with g > 0 pointing down.
double launch_speed(double y0, double y1, int k, double dt, double g) {
  const double kd = static_cast<double>(k);
  return (y1 - y0 + g * dt * dt * kd * (kd + 1.0) / 2.0) / (kd * dt);
}

// Launch speed for a body at y0 whose bottom reaches `rest` (the centre
// height at which it touches what it lands on) at step `step`: one step
// before, it is above by half the distance it falls in a step, so the first
// step in contact penetrates by at most half of that (a landing at 37 m/s
// moves 0.62 m per step; the wake box is 0.5 m tall).
double arrival_speed(double y0, double rest, int step, double dt, double g) {
  double clearance = 0.0;
  double v0 = 0.0;
  for (int i = 0; i < 2; ++i) {  // the clearance depends on the speed, which barely depends on it
    v0 = launch_speed(y0, rest + clearance, step - 1, dt, g);
    clearance = 0.5 * std::abs(v0 - g * dt * step) * dt;
  }
  return v0;
}


}  // namespace

Scene make_alternating_load(const SceneParams& params) {
  Scene scene;
  scene.name = "alternating-load";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const double dt = scene.settings.dt;
  const double g = -scene.settings.gravity.y();
  const int n = params.n > 0 ? params.n : kDefaultLoadCubes;
  const int columns = (n + 2 * kLayers - 1) / (2 * kLayers);  // per half
  const int per_spot = kSpotSide * kSpotSide;
  const int spots = (columns + per_spot - 1) / per_spot;      // per half
  const int spot_rows = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(spots))));  // along z
  const int spot_cols = (spots + spot_rows - 1) / spot_rows;                                 // along x
  const double spot_width = kSpotSide * kColumnPitch;
  const double spot_pitch = spot_width + kSpotGap;

  // Ground under both halves and the gap, plus the margin.
  const double half_x = kHalfGap + spot_cols * spot_pitch + kGroundMargin;
  const double half_z = 0.5 * spot_rows * spot_pitch + kGroundMargin;
  scene.bodies.push_back(static_box(0, Vec3(half_x, 0.5, half_z), Vec3(0.0, -0.5, 0.0)));

  // Column centres of the left half, spot by spot (nearest x = 0 first),
  // row-major within a spot; the right half mirrors them in x.
  std::vector<Vec3> left;
  for (int c = 0; c < columns; ++c) {
    const int spot = c / per_spot, in_spot = c % per_spot;
    const double spot_x = -(kHalfGap + 0.5 * spot_width + (spot % spot_cols) * spot_pitch);
    const double spot_z = ((spot / spot_cols) - 0.5 * (spot_rows - 1)) * spot_pitch;
    const double offset = 0.5 * (kSpotSide - 1) * kColumnPitch;
    left.emplace_back(spot_x + (in_spot / kSpotSide) * kColumnPitch - offset, 0.0,
                      spot_z + (in_spot % kSpotSide) * kColumnPitch - offset);
  }

  // Window j's step; side 0 (left) lands in window 0 and is woken in 2,
  // side 1 (right) in 1 and 3.
  const auto window_step = [](int j) { return kFirstLanding + j * kWindowSteps; };
  const double bottom_y = 0.5 + (kLayerPitch - 1.0);  // the bottom cube starts 0.5 m above the ground
  const double top_face = bottom_y + (kLayers - 1) * kLayerPitch + 0.5;
  const double wake_y = top_face + kWakeStartAbove + 0.5 * kWakeEdge;
  const double settled_top = kLayers * 1.0;  // a column at rest: cubes stacked face to face
  BodyId id = 1;
  for (int side = 0; side < 2; ++side) {
    const double v_column = arrival_speed(bottom_y, 0.5, window_step(side), dt, g);
    for (const Vec3& c : left) {
      const double x = side == 0 ? c.x() : -c.x();
      for (int layer = 0; layer < kLayers; ++layer) {
        Body cube = dynamic_box(id++, Vec3::Constant(0.5), 1.0, Vec3(x, bottom_y + layer * kLayerPitch, c.z()),
                                yaw(rng.uniform(0.0, 0.5 * std::numbers::pi)));
        cube.linear_velocity = Vec3(0.0, v_column, 0.0);
        scene.bodies.push_back(cube);
      }
    }
  }
  for (int side = 0; side < 2; ++side) {
    const double v_wake = arrival_speed(wake_y, settled_top + 0.5 * kWakeEdge, window_step(side + 2), dt, g);
    for (const Vec3& c : left) {
      Body wake = dynamic_box(id++, Vec3::Constant(0.5 * kWakeEdge), kWakeMass,
                              Vec3(side == 0 ? c.x() : -c.x(), wake_y, c.z()),
                              yaw(rng.uniform(0.0, 0.5 * std::numbers::pi)));
      wake.linear_velocity = Vec3(0.0, v_wake, 0.0);
      scene.bodies.push_back(wake);
    }
  }
  return scene;
}

}  // namespace soda::detail
