// Soak scenes: long runs that exercise one mechanism many times.
#include <algorithm>
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {

// border-shuttle: lanes of spheres sliding frictionless along x on the
// ground of a long walled box, half the lanes towards +x from the -x end,
// half towards -x from the +x end, so a thin territory map (grid:Kx1x1) sees
// bodies cross its borders in both directions. Each crossing is a migration
// (docs/soak.md). Energy-stable by construction: no two spheres touch while
// they slide (one speed per lane, lanes 0.75 m apart), the ground only
// cancels gravity (friction 0, restitution 0) and nothing is elastic: a lane
// reaching the far wall comes to rest against it, its spheres against each
// other (restitution 0 everywhere). Bullet's
// elastic contacts (restitution 1) were not: the energy of spheres bouncing
// between walls drifted up and down by random walk and ran away (x 2,000 in
// 60,000 steps at 0.8..1.2 m/s, x 5 in 3,000 steps at 4..8 m/s).
Scene make_border_shuttle(const SceneParams& params) {
  Scene scene;
  scene.name = "border-shuttle";
  scene.seed = params.seed;
  const int n = count_or_default(params, 200, 20000);
  constexpr double kRadius = 0.25;
  constexpr double kGap = 1.0;            // along a lane, centre to centre: > 2 radii
  constexpr int kPerLane = 10;            // spheres one behind the other, one speed: never closer
  constexpr double kLaneSpacing = 0.75;   // across z, centre to centre: > 2 radii
  constexpr double kHalfLength = 50.0;    // inner faces of the end walls at x = +-50 m
  constexpr double kMinSpeed = 4.0;       // m/s along x: far above the sleeping threshold
  constexpr double kMaxSpeed = 8.0;       // 0.13 m per step at 1/60 s: far below a cell
  constexpr double kWallHalfThickness = 0.5;
  constexpr double kWallHalfHeight = 1.0;
  const int lanes = (n + kPerLane - 1) / kPerLane;
  const double half_width = 0.5 * lanes * kLaneSpacing;  // inner faces of the side walls at z = +-half_width
  const double outer_x = kHalfLength + 2 * kWallHalfThickness;
  const double outer_z = half_width + 2 * kWallHalfThickness;
  scene.bodies.push_back(flat_ground(std::max(outer_x, outer_z) + 1.0, 0.0));  // friction 0, restitution 0
  const double cx = kHalfLength + kWallHalfThickness, cz = half_width + kWallHalfThickness;
  const Vec3 along_z(kWallHalfThickness, kWallHalfHeight, outer_z);
  const Vec3 along_x(outer_x, kWallHalfHeight, kWallHalfThickness);
  BodyId id = 1;
  for (const Body& w : {static_box(0, along_z, Vec3(cx, kWallHalfHeight, 0.0)),
                        static_box(0, along_z, Vec3(-cx, kWallHalfHeight, 0.0)),
                        static_box(0, along_x, Vec3(0.0, kWallHalfHeight, cz)),
                        static_box(0, along_x, Vec3(0.0, kWallHalfHeight, -cz))}) {
    Body wall = w;
    wall.id = id++;
    wall.friction = 0.0;
    wall.restitution = 0.0;
    scene.bodies.push_back(wall);
  }
  SceneRandom rng(params.seed);
  double speed = 0;
  for (int i = 0; i < n; ++i) {
    const int lane = i / kPerLane, place = i % kPerLane;
    if (place == 0) speed = rng.uniform(kMinSpeed, kMaxSpeed);
    const double direction = lane % 2 == 0 ? 1.0 : -1.0;  // even lanes start at -x and go +x
    const double x = -direction * (kHalfLength - kRadius - 0.25 - place * kGap);
    const double z = -half_width + (lane + 0.5) * kLaneSpacing;
    Body b = dynamic_sphere(id++, kRadius, 1.0, Vec3(x, kRadius, z));
    b.friction = 0.0;
    b.restitution = 0.0;
    b.linear_velocity = Vec3(direction * speed, 0.0, 0.0);
    scene.bodies.push_back(b);
  }
  return scene;
}

}  // namespace soda::detail
