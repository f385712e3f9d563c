// Soak scenes: long runs that exercise one mechanism many times.
#include <algorithm>
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {

// border-shuttle: spheres sliding frictionless on the ground of a long
// walled box, bouncing elastically off the walls and each other, so they
// cross the borders of a thin territory map (grid:16x1x1) back and forth for
// as long as the run lasts. Each crossing is a migration (docs/soak.md).
Scene make_border_shuttle(const SceneParams& params) {
  Scene scene;
  scene.name = "border-shuttle";
  scene.seed = params.seed;
  const int n = count_or_default(params, 200, 20000);
  constexpr double kRadius = 0.25;
  constexpr double kSpacing = 1.0;        // start spots, > 2 radii: nothing touches at the start
  constexpr double kHalfWidth = 2.0;      // inner faces of the side walls at z = +-2
  constexpr double kMinSpeed = 4.0;       // m/s along x: far above the sleeping threshold
  constexpr double kMaxSpeed = 8.0;       // 0.13 m per step at 1/60 s: far below a cell
  constexpr double kWallHalfThickness = 0.5;
  constexpr double kWallHalfHeight = 1.0;
  // Spots: rows of 4 across z, as many columns along x as needed, filling
  // the box (1 m along x per 4 bodies): a dense shuttle, many crossings.
  const int rows = 4;
  const int columns = (n + rows - 1) / rows;
  const double half_length = 0.5 * columns * kSpacing + 0.5;  // inner faces at x = +-half_length
  const double outer_x = half_length + 2 * kWallHalfThickness;
  const double outer_z = kHalfWidth + 2 * kWallHalfThickness;
  scene.bodies.push_back(flat_ground(outer_x + 1.0, 0.0));
  scene.bodies.back().restitution = 1.0;
  const double cx = half_length + kWallHalfThickness, cz = kHalfWidth + kWallHalfThickness;
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
    wall.restitution = 1.0;  // Bullet multiplies the two: 1
    scene.bodies.push_back(wall);
  }
  SceneRandom rng(params.seed);
  for (int i = 0; i < n; ++i) {
    const double x = -0.5 * (columns - 1) * kSpacing + (i / rows) * kSpacing;
    const double z = -1.5 + (i % rows);
    Body b = dynamic_sphere(id++, kRadius, 1.0, Vec3(x, kRadius, z));
    b.friction = 0.0;
    b.restitution = 1.0;
    const double speed = rng.uniform(kMinSpeed, kMaxSpeed);
    b.linear_velocity = Vec3(rng.uniform(0.0, 1.0) < 0.5 ? -speed : speed, 0.0, rng.uniform(-1.0, 1.0));
    scene.bodies.push_back(b);
  }
  return scene;
}

}  // namespace soda::detail
