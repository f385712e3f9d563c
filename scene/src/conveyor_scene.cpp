// conveyor (docs/scenes.md): kinematic platforms (docs/scene-format.md,
// "Kinematic bodies") carrying boxes across territory borders — four
// conveyor pallets shuttling along x, a turntable and an elevator — over a
// ground the boxes they drop land on.
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultBoxes = 120;
constexpr double kHalfBox = 0.2;      // m: the boxes' half extent
constexpr double kSpeed = 2.0;        // m/s: the pallets along x
constexpr double kTravel = 8.0;       // m: the pallets shuttle between x = -8 and 8
constexpr double kPlatformY = 0.6;    // m: the platforms' centres at rest (0.1 m thick, top at 0.7)
const Vec3 kPlatformHalf(1.5, 0.1, 1.0);

Body platform(BodyId id, const Shape& shape, KinematicPath path) {
  Body b;
  b.id = id;
  b.is_static = true;
  b.kinematic = true;
  b.shape = shape;
  b.friction = 0.8;
  b.path = std::move(path);
  b.position = b.path.keys.front().position;
  b.orientation = b.path.keys.front().orientation;
  return b;
}

PathKey key(double time, const Vec3& position, const Quat& orientation = Quat::Identity()) {
  return PathKey{time, position, orientation};
}

// A pallet starting at x0 towards +x, to kTravel, back to -kTravel and to
// x0 again: one period, looping.
KinematicPath pallet(double x0, double z) {
  KinematicPath p;
  p.loop = true;
  const double to_end = (kTravel - x0) / kSpeed, across = 2.0 * kTravel / kSpeed;
  p.keys.push_back(key(0.0, Vec3(x0, kPlatformY, z)));
  if (to_end > 0.0) p.keys.push_back(key(to_end, Vec3(kTravel, kPlatformY, z)));
  p.keys.push_back(key(to_end + across, Vec3(-kTravel, kPlatformY, z)));
  const double back = (x0 + kTravel) / kSpeed;
  if (back > 0.0) p.keys.push_back(key(to_end + across + back, Vec3(x0, kPlatformY, z)));
  return p;
}

}  // namespace

Scene make_conveyor(const SceneParams& params) {
  Scene scene = start_scene("conveyor", params);
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultBoxes;
  scene.bodies.push_back(flat_ground(kTravel + 6.0, 0.6));
  BodyId id = 1;
  // Four pallets in lanes along x, each starting at its own place.
  for (int lane = 0; lane < 4; ++lane)
    scene.bodies.push_back(
        platform(id++, Shape::box(kPlatformHalf), pallet(-kTravel + 4.0 * lane, -7.5 + 3.0 * lane)));
  // A turntable of 2 m radius turning about y once in 12 s, on the border
  // x = 0 of a two-way split, beyond the lanes.
  {
    KinematicPath p;
    p.loop = true;
    const Vec3 at(0.0, kPlatformY, 6.0);
    for (int k = 0; k <= 3; ++k)
      p.keys.push_back(key(4.0 * k, at, Quat(Eigen::AngleAxisd(2.0943951023931957 * k, Vec3::UnitY()))));
    scene.bodies.push_back(platform(id++, Shape::cylinder(Vec3(2.0, 0.1, 2.0)), p));
  }
  // An elevator resting 4 s at the bottom (long enough for what it carries
  // to fall asleep), rising 3 m in 3 s, resting 1 s and coming down in 3 s.
  {
    KinematicPath p;
    p.loop = true;
    const Vec3 low(5.0, kPlatformY, 10.0), high(5.0, kPlatformY + 3.0, 10.0);
    p.keys = {key(0.0, low), key(4.0, low), key(7.0, high), key(8.0, high), key(11.0, low)};
    scene.bodies.push_back(platform(id++, Shape::box(kPlatformHalf), p));
  }
  const int platforms = static_cast<int>(id) - 1;
  // The boxes, round robin over the platforms, in layers of 4 x 3 over each
  // platform's start, dropped from a few centimetres (jittered, turned a little).
  std::vector<int> placed(static_cast<std::size_t>(platforms), 0);
  for (int i = 0; i < n; ++i) {
    const int p = i % platforms;
    const Body& under = scene.bodies[static_cast<std::size_t>(p + 1)];
    const int slot = placed[static_cast<std::size_t>(p)]++;
    const int layer = slot / 12, row = (slot / 4) % 3, col = slot % 4;
    Body b;
    b.id = id++;
    b.shape = Shape::box(Vec3(kHalfBox, kHalfBox, kHalfBox));
    b.mass = 1.0;
    b.friction = 0.8;
    b.position = under.position + Vec3(-1.05 + 0.7 * col + rng.uniform(-0.05, 0.05),
                                       0.1 + kHalfBox + 0.05 + 0.45 * layer,
                                       -0.6 + 0.6 * row + rng.uniform(-0.05, 0.05));
    b.orientation = Quat(Eigen::AngleAxisd(rng.uniform(-0.3, 0.3), Vec3::UnitY()));
    scene.bodies.push_back(std::move(b));
  }
  return scene;
}

}  // namespace soda::detail
