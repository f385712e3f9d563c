// Border scenes (BENCHMARKS.md, docs/scenes.md): small scenes whose contacts
// sit on territory borders, to exercise synchronisation. Also the building
// blocks shared with stress_scenes.cpp (generators.h).
//
// Geometry every border scene keeps, so that tests can put borders where the
// contacts are (GridOptions with origin 0 and cell size 2 m: grid:2x1x2 and
// grid:8x1x1 cut at x = 0 and z = 0):
//  1. the dynamic bodies' initial bounds are symmetric about x = 0 (and z = 0
//     where a corner matters), so regular blocks cut at x = 0 / z = 0;
//  2. every dynamic body's bounding-sphere diameter is <= 2 m (one cell);
//  3. no body starts faster than 20 m/s: < 0.34 m per 1/60 s step, so a body
//     never crosses more than its halo cell in one step.
#include <cmath>
#include <numbers>
#include <vector>

#include "generators.h"
#include "soda/scene/validate.h"

namespace soda::detail {

int magnitude_or_default(const SceneParams& params, int default_n) { return params.n >= 1 ? params.n : default_n; }

int count_or_default(const SceneParams& params, int default_n, int max_n) {
  if (params.n == 0) return default_n;
  if (params.n > max_n)
    throw SceneError("--n " + std::to_string(params.n) + " is too large for this scene (at most " +
                     std::to_string(max_n) + "; 0 for the default " + std::to_string(default_n) + ")");
  return params.n;
}

Body flat_ground(double half_footprint, double friction, double centre_x, double half_thickness) {
  Body g = static_box(kGroundId, Vec3(half_footprint, half_thickness, half_footprint),
                      Vec3(centre_x, -half_thickness, 0.0));
  g.friction = friction;
  return g;
}

Body static_box(BodyId id, const Vec3& half_extents, const Vec3& position, const Quat& orientation) {
  Body b;
  b.id = id;
  b.is_static = true;
  b.shape = Shape::box(half_extents);
  b.mass = 0.0;
  b.friction = 0.5;
  b.restitution = 0.0;
  b.position = position;
  b.orientation = orientation;
  return b;
}

Body dynamic_box(BodyId id, const Vec3& half_extents, double mass, const Vec3& position,
                 const Quat& orientation) {
  Body b;
  b.id = id;
  b.shape = Shape::box(half_extents);
  b.mass = mass;
  b.friction = 0.5;
  b.restitution = 0.0;
  b.position = position;
  b.orientation = orientation;
  return b;
}

Body dynamic_sphere(BodyId id, double radius, double mass, const Vec3& position) {
  Body b;
  b.id = id;
  b.shape = Shape::sphere(radius);
  b.mass = mass;
  b.friction = 0.5;
  b.restitution = 0.0;
  b.position = position;
  return b;
}

Scene make_seam_stack(const SceneParams& params) {
  Scene scene;
  scene.name = "seam-stack";
  scene.seed = params.seed;
  const int n = count_or_default(params, 8, 50);  // boxes per tower
  // Gaps between stacked boxes: the tower settles by a few millimetres in the
  // first steps instead of starting in contact.
  constexpr double kGap = 0.001;
  constexpr double kSeamTowerZ = 3.0;  // on the plane x = 0, away from z = 0
  scene.bodies.push_back(flat_ground(kSeamTowerZ + 0.5 + kGroundMargin, 0.5));
  // Ids 1..n: the tower on the x = 0 plane; n+1..2n: the tower on the corner
  // x = 0, z = 0 where four territories of grid:2x1x2 meet.
  BodyId id = 1;
  for (const double z : {kSeamTowerZ, 0.0})
    for (int i = 0; i < n; ++i)
      scene.bodies.push_back(dynamic_box(id++, kUnitHalf, 1.0, Vec3(0.0, 0.5 + i * (1.0 + kGap), z)));
  return scene;
}

Scene make_cross_traffic(const SceneParams& params) {
  Scene scene;
  scene.name = "cross-traffic";
  scene.seed = params.seed;
  constexpr double kRingRadius = 6.0;
  constexpr double kSpeed = 5.0;          // m/s
  constexpr double kBoxFriction = 0.1;    // times the ground's 1.0: mu = 0.1 on the ground
  constexpr double kGroundFriction = 1.0;
  scene.bodies.push_back(flat_ground(kRingRadius + 0.5 + kGroundMargin, kGroundFriction));
  // Ids 1..8: a ring of boxes sliding to the centre, one every 45 degrees from
  // +x towards +z. The four on the axes slide along the borders x = 0 / z = 0,
  // the four on the diagonals (turned 45 degrees to face the centre) aim at
  // the corner. Directions are written out so that zeros are exact.
  const double s = std::sqrt(0.5);
  const double ring[8][2] = {{1, 0}, {s, s}, {0, 1}, {-s, s}, {-1, 0}, {-s, -s}, {0, -1}, {s, -s}};
  const Quat diagonal(Eigen::AngleAxisd(0.25 * std::numbers::pi, Vec3::UnitY()));
  BodyId id = 1;
  for (int k = 0; k < 8; ++k) {
    const Vec3 dir(ring[k][0], 0.0, ring[k][1]);
    Body b = dynamic_box(id++, kUnitHalf, 1.0, kRingRadius * dir + Vec3(0.0, 0.5, 0.0),
                         k % 2 == 1 ? diagonal : Quat::Identity());
    b.friction = kBoxFriction;
    b.linear_velocity = -kSpeed * dir;
    scene.bodies.push_back(b);
  }
  // Ids 9..12: a pinwheel of boxes sliding tangentially, one per quadrant,
  // crossing x = 0 (at z = +-2) or z = 0 (at x = -+2) about when the ring
  // boxes on the axes pass there.
  const double cross[4][4] = {// x, z, vx, vz
                              {-4, 2, kSpeed, 0},
                              {4, -2, -kSpeed, 0},
                              {-2, -4, 0, kSpeed},
                              {2, 4, 0, -kSpeed}};
  for (const auto& c : cross) {
    Body b = dynamic_box(id++, kUnitHalf, 1.0, Vec3(c[0], 0.5, c[1]));
    b.friction = kBoxFriction;
    b.linear_velocity = Vec3(c[2], 0.0, c[3]);
    scene.bodies.push_back(b);
  }
  return scene;
}

Scene make_projectile(const SceneParams& params) {
  Scene scene;
  scene.name = "projectile";
  scene.seed = params.seed;
  constexpr double kArenaHalf = 15.0;  // inner faces of the walls at x, z = +-15
  constexpr double kWallHalfThickness = 0.5;
  constexpr double kWallHalfHeight = 1.0;
  constexpr double kRestitution = 0.8;  // sphere and walls; Bullet multiplies: 0.64
  constexpr double kRadius = 0.25;
  const double outer = kArenaHalf + 2 * kWallHalfThickness;
  scene.bodies.push_back(flat_ground(outer + kGroundMargin, 0.5));
  // Ids 1..4: walls at +x, -x, +z, -z, overlapping at the corners.
  const double c = kArenaHalf + kWallHalfThickness;
  const Vec3 along_z(kWallHalfThickness, kWallHalfHeight, outer);
  const Vec3 along_x(outer, kWallHalfHeight, kWallHalfThickness);
  const std::vector<Body> walls = {static_box(1, along_z, Vec3(c, kWallHalfHeight, 0.0)),
                                   static_box(2, along_z, Vec3(-c, kWallHalfHeight, 0.0)),
                                   static_box(3, along_x, Vec3(0.0, kWallHalfHeight, c)),
                                   static_box(4, along_x, Vec3(0.0, kWallHalfHeight, -c))};
  for (Body w : walls) {
    w.restitution = kRestitution;
    scene.bodies.push_back(w);
  }
  // Id 5: the sphere, from the corner x = 0, z = 0 along (0.8, 0, 0.6) at
  // 20 m/s (1/3 m per step), frictionless so it slides and keeps its speed
  // between bounces.
  Body ball = dynamic_sphere(5, kRadius, 1.0, Vec3(0.0, kRadius, 0.0));
  ball.friction = 0.0;
  ball.restitution = kRestitution;
  ball.linear_velocity = Vec3(16.0, 0.0, 12.0);
  scene.bodies.push_back(ball);
  // Ids 6..9: unit boxes at (+-8, +-6); the first one sits on the sphere's
  // initial line.
  BodyId id = 6;
  for (const double x : {8.0, -8.0})
    for (const double z : {6.0, -6.0})
      scene.bodies.push_back(dynamic_box(id++, kUnitHalf, 1.0, Vec3(x, 0.5, z)));
  return scene;
}

Scene make_thrown_ball(const SceneParams& params) {
  Scene scene;
  scene.name = "thrown-ball";
  scene.seed = params.seed;
  const int speed = magnitude_or_default(params, 40);  // m/s
  constexpr double kArenaHalf = 6.0;  // inner faces of the walls at x, z = +-6
  constexpr double kWallHalfThickness = 0.5;
  constexpr double kWallHalfHeight = 1.0;
  constexpr double kRestitution = 0.8;  // sphere and walls; Bullet multiplies: 0.64
  constexpr double kRadius = 0.2;       // the ball: cells are 0.4 m by default
  constexpr double kBrickHalf = 0.11;   // bounding diameter 0.38 m: fits the ball's cell
  constexpr int kBricks = 6;            // 0.3 m apart: a 1.8 m row, longer than a step at 100 m/s
  const double outer = kArenaHalf + 2 * kWallHalfThickness;
  scene.bodies.push_back(flat_ground(outer + kGroundMargin, 0.5));
  // Ids 1..4: walls at +x, -x, +z, -z, overlapping at the corners.
  const double c = kArenaHalf + kWallHalfThickness;
  const Vec3 along_z(kWallHalfThickness, kWallHalfHeight, outer);
  const Vec3 along_x(outer, kWallHalfHeight, kWallHalfThickness);
  for (Body w : {static_box(1, along_z, Vec3(c, kWallHalfHeight, 0.0)),
                 static_box(2, along_z, Vec3(-c, kWallHalfHeight, 0.0)),
                 static_box(3, along_x, Vec3(0.0, kWallHalfHeight, c)),
                 static_box(4, along_x, Vec3(0.0, kWallHalfHeight, -c))}) {
    w.restitution = kRestitution;
    scene.bodies.push_back(w);
  }
  // Id 5: the ball, from (-1.5, 0, 0) along (0.96, 0, 0.28), frictionless.
  const Vec3 start(-1.5, kRadius, 0.0), direction(0.96, 0.0, 0.28);
  Body ball = dynamic_sphere(5, kRadius, 1.0, start);
  ball.friction = 0.0;
  ball.restitution = kRestitution;
  ball.linear_velocity = speed * direction;
  scene.bodies.push_back(ball);
  // Ids 6..11: a row of 1 kg bricks on the ball's line, 1.0 to 2.5 m ahead
  // (2 cm gaps): whatever its speed, some step finds the ball in the row.
  for (int i = 0; i < kBricks; ++i) {
    Vec3 p = start + (1.0 + 0.3 * i) * direction;
    p.y() = kBrickHalf;
    scene.bodies.push_back(dynamic_box(BodyId(6 + i), Vec3::Constant(kBrickHalf), 1.0, p));
  }
  return scene;
}

Scene make_chain(const SceneParams& params) {
  Scene scene;
  scene.name = "chain";
  scene.seed = params.seed;
  const int n = count_or_default(params, 16, 200);
  constexpr double kPushSpeed = 3.0;  // m/s along +x, first box only
  const double first_x = -0.5 * (n - 1);  // centres -L/2 + 0.5 .. L/2 - 0.5, L = n metres
  scene.bodies.push_back(flat_ground(0.5 * n + kGroundMargin, 0.5));
  for (int i = 0; i < n; ++i) {
    Body b = dynamic_box(static_cast<BodyId>(i + 1), kUnitHalf, 1.0, Vec3(first_x + i, 0.5, 0.0));
    if (i == 0) b.linear_velocity = Vec3(kPushSpeed, 0.0, 0.0);
    scene.bodies.push_back(b);
  }
  return scene;
}

}  // namespace soda::detail
