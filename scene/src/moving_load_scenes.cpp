// Moving-load scenes for load-balance experiments (docs/scenes.md,
// docs/loadbalance.md): the cost of the scene moves or
// grows in one region while the rest stays cheap, so fixed territories
// fall out of balance.
//
// Shared rules (each keeps the run inside the exactness contract and the
// experiment meaningful):
//  1. the map box (the dynamic bodies' initial cells plus a margin) spans
//     the whole region the load will visit: every scene puts resting bodies
//     (a catch, a fence, floor markers) at the far end of the path, because
//     cells outside the box clamp to its border and a policy can only move
//     box cells;
//  2. bodies that move together start apart (gaps of 0.25 m or more) and
//     keep their gaps until they pile up: many small islands while the load
//     travels, not one giant island that a single world would solve;
//  3. speeds stay below 20 m/s (a third of a unit cube per step), so the
//     neighbourhood reach of the initial scene holds and no contact is deep.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr double kPitch = 1.25;          // m between the centres of neighbouring unit cubes: 0.25 m gaps
constexpr double kRestGap = 0.001;       // m between a resting body and the wall it rests against


Body wall(BodyId id, const Vec3& half_extents, const Vec3& position, double friction) {
  Body w = static_box(id, half_extents, position);
  w.friction = friction;
  return w;
}

int steps_for(double seconds, double dt) { return static_cast<int>(std::ceil(seconds / dt)); }

}  // namespace

// The sliding block shared by hotspot and drift: n unit cubes, lanes across
// z by rows along x at kPitch, seeded yaws within +-kMaxYaw (so 0.25 m gaps
// hold: a yawed face reaches 0.547 m), cube friction 1.0 (mu = the
// ground's), all at kSlideSpeed along +x with the back row at x = 0: they
// all decelerate alike, so the gaps stay until something stops the front.
struct SlidingBlock {
  static constexpr double kSlideSpeed = 8.0;  // m/s: 0.13 m per step, the block crosses a 1.73 m cell in 13 steps
  static constexpr double kMaxYaw = 0.1;      // rad
  int lanes = 0, rows = 0;
  double length = 0, half_width = 0;
  double front = 0;  // x of the front row's centres

  explicit SlidingBlock(int n)
      : lanes(static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))))),
        rows((n + lanes - 1) / lanes),
        length(rows * kPitch),
        half_width(0.5 * lanes * kPitch),
        front(length - 0.5 * kPitch) {}

  double lane_z(int lane) const { return (lane + 0.5) * kPitch - half_width; }

  // Cubes front row first, lane by lane from -z; a partial row is the last.
  void add(Scene& scene, BodyId& id, int n, SceneRandom& rng) const {
    for (int k = 0; k < n; ++k) {
      const int row = k / lanes, lane = k % lanes;
      const Vec3 p(front - row * kPitch, 0.5, lane_z(lane));
      Body cube = dynamic_box(id++, kUnitHalf, 1.0, p, yaw(rng.uniform(-kMaxYaw, kMaxYaw)));
      cube.friction = 1.0;
      cube.linear_velocity = Vec3(kSlideSpeed, 0.0, 0.0);
      scene.bodies.push_back(cube);
    }
  }
};

// hotspot — the sliding block on a ground of low friction runs into the
// catch, a row of cubes resting against a wall at the far end of a track
// three block lengths long, where it jams into a pile and falls asleep.
// The ground's friction is chosen so that the block reaches the catch at
// kArrivalSpeed.
Scene make_hotspot(const SceneParams& params) {
  Scene scene;
  scene.name = "hotspot";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const double g = -scene.settings.gravity.y();
  constexpr double kArrivalSpeed = 4.0;  // m/s at the catch: a jam, not a crash
  constexpr double kWallFriction = 1.0;  // cube 1.0 x wall 1.0: the pile holds
  constexpr double kSettleSeconds = 4.0; // jam, come to rest, 2 s below the sleeping thresholds
  const int n = count_or_default(params, 400, 20000);
  const SlidingBlock block(n);
  const double v0 = SlidingBlock::kSlideSpeed;
  const double track = 3.0 * block.length;  // the wall's inner face at x = track; the block's back at x = 0
  const double catch_x = track - 0.5 - kRestGap;
  const double distance = (catch_x - 0.5) - (block.front + 0.5);  // front faces' travel to the catch
  const double deceleration = (v0 * v0 - kArrivalSpeed * kArrivalSpeed) / (2.0 * distance);

  Body ground = flat_ground(0.5 * track + kGroundMargin, deceleration / g, 0.5 * track);
  scene.bodies.push_back(ground);  // id 0; cube friction 1.0, so mu = the ground's
  scene.bodies.push_back(
      wall(1, Vec3(0.5, 1.0, block.half_width + 1.0), Vec3(track + 0.5, 1.0, 0.0), kWallFriction));
  BodyId id = 2;
  block.add(scene, id, n, rng);
  for (int lane = 0; lane < block.lanes; ++lane) {
    Body cube = dynamic_box(id++, kUnitHalf, 1.0, Vec3(catch_x, 0.5, block.lane_z(lane)));
    cube.friction = 1.0;
    scene.bodies.push_back(cube);
  }
  const double arrival = (v0 - kArrivalSpeed) / deceleration;
  scene.settings.steps = steps_for(arrival + kSettleSeconds, scene.settings.dt);
  return scene;
}

// drift — hotspot without the pile: the sliding block comes to rest by
// friction alone, its gaps kept (every cube its own island to the end), its
// front faces at x = 3 L - 1, kStopGap short of two marker cubes resting at
// the side lanes' ends (they hold the map box over the whole track). With
// grid:2x1x1 the block starts wholly in the first half of the box and stops
// wholly in the second (its back at 2 L - 1 > the cut at about 1.5 L + 0.75
// from 3 rows on): the load drifts from one half to the other and no island
// ever grows past one cube.
Scene make_drift(const SceneParams& params) {
  Scene scene;
  scene.name = "drift";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const double g = -scene.settings.gravity.y();
  constexpr double kStopGap = 2.0;        // m between the stopped front faces and the markers
  constexpr double kSettleSeconds = 3.0;  // come to rest, 2 s below the sleeping thresholds, 1 s asleep
  const int n = count_or_default(params, 400, 20000);
  const SlidingBlock block(n);
  const double v0 = SlidingBlock::kSlideSpeed;
  const double track = 3.0 * block.length + kStopGap;  // the markers' far faces
  const double marker_x = track - 0.5;
  const double distance = (marker_x - 0.5 - kStopGap) - (block.front + 0.5);  // front faces' travel
  const double deceleration = v0 * v0 / (2.0 * distance);

  scene.bodies.push_back(flat_ground(0.5 * track + kGroundMargin, deceleration / g, 0.5 * track));  // id 0
  BodyId id = 1;
  block.add(scene, id, n, rng);
  for (int lane : {0, block.lanes - 1}) {
    Body cube = dynamic_box(id++, kUnitHalf, 1.0, Vec3(marker_x, 0.5, block.lane_z(lane)));
    cube.friction = 1.0;
    scene.bodies.push_back(cube);
    if (block.lanes == 1) break;
  }
  scene.settings.steps = steps_for(v0 / deceleration + kSettleSeconds, scene.settings.dt);
  return scene;
}

// avalanche — a block of unit cubes resting on a 30 degree slope (friction
// 0.4 < tan 30: it slides from rest, a = g (sin 30 - 0.4 cos 30) = 1.51
// m/s^2) flows down onto a flat run-out of the same friction and piles up
// at the foot, rows arriving one after another. A fence (a row of cubes
// resting against a wall at the end of the run-out) holds the map box over
// the run-out.
Scene make_avalanche(const SceneParams& params) {
  Scene scene;
  scene.name = "avalanche";
  scene.seed = params.seed;
  const double g = -scene.settings.gravity.y();
  constexpr double kAngle = std::numbers::pi / 6.0;
  constexpr double kCubeFriction = 0.4;   // x 1.0 (slope, ground): mu = 0.4
  constexpr double kFreeSlope = 8.0;      // m of slope below the block: the front row is moving at 4.9 m/s at the foot
  constexpr double kSlopeAbove = 2.0;     // m of slope above the block
  constexpr double kSettleSeconds = 4.0;
  const int n = count_or_default(params, 400, 20000);
  const int lanes = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));  // across z
  const int rows = (n + lanes - 1) / lanes;                                           // up the slope
  const double half_width = 0.5 * lanes * kPitch;
  const double slope_length = kFreeSlope + rows * kPitch + kSlopeAbove;
  // Arc length s up the slope from its foot at the origin; the surface point
  // at s is -s * down.
  const Vec3 down(std::cos(kAngle), -std::sin(kAngle), 0.0);
  const Vec3 normal(std::sin(kAngle), std::cos(kAngle), 0.0);
  const Quat tilt(Eigen::AngleAxisd(-kAngle, Vec3::UnitZ()));  // local x -> down, y -> normal
  // The run-out: a cube stops v^2 / (2 mu g) = (2 a s) / (2 mu g) = 0.38 s
  // past the foot; the fence stands beyond the farthest, plus 5 m.
  const double a = g * (std::sin(kAngle) - kCubeFriction * std::cos(kAngle));
  const double run_out = 0.5 * (kFreeSlope + rows * kPitch) + 5.0;
  const double x_lo = -slope_length * std::cos(kAngle);
  scene.bodies.push_back(flat_ground(0.5 * (run_out - x_lo) + kGroundMargin, 1.0, 0.5 * (run_out + x_lo)));
  // The slope continues 1 m under the ground at the foot (a step-free join).
  const double s_lo = -1.0, s_hi = slope_length;
  Body slope = static_box(1, Vec3(0.5 * (s_hi - s_lo), 0.5, half_width + 1.0),
                          -0.5 * (s_lo + s_hi) * down - 0.5 * normal, tilt);
  slope.friction = 1.0;
  scene.bodies.push_back(slope);
  scene.bodies.push_back(wall(2, Vec3(0.5, 1.0, half_width + 1.0), Vec3(run_out + 0.5, 1.0, 0.0), 1.0));
  BodyId id = 3;
  for (int k = 0; k < n; ++k) {  // lowest row first, lane by lane from -z
    const int row = k / lanes, lane = k % lanes;
    const double s = kFreeSlope + (row + 0.5) * kPitch;
    const Vec3 p = -s * down + (0.5 + kRestGap) * normal + Vec3(0.0, 0.0, (lane + 0.5) * kPitch - half_width);
    Body cube = dynamic_box(id++, kUnitHalf, 1.0, p, tilt);
    cube.friction = kCubeFriction;
    scene.bodies.push_back(cube);
  }
  for (int lane = 0; lane < lanes; ++lane) {
    Body cube = dynamic_box(id++, kUnitHalf, 1.0, Vec3(run_out - 0.5 - kRestGap, 0.5, (lane + 0.5) * kPitch - half_width));
    cube.friction = kCubeFriction;
    scene.bodies.push_back(cube);
  }
  const double top = kFreeSlope + rows * kPitch;  // the last row's travel to the foot
  scene.settings.steps = steps_for(std::sqrt(2.0 * top / a) + kSettleSeconds, scene.settings.dt);
  return scene;
}

}  // namespace soda::detail
