// Bodies larger than a cell (docs/determinism.md, "Bodies of any size"):
// big-bodies (2 m, 5 m and 20 m boxes, capsules and hulls falling among unit
// cubes), and the two stress scenes of docs/stress.md, plank-pile (a long
// plank dropped on a pile of cubes) and heavy-slide (a heavy 5 m box sliding
// across territory borders).
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultBigBodiesCubes = 300;

// A convex hull shaped as a prism: a triangle of `width` by `height` (m)
// extruded `length` metres along x, centred on its local origin.
Shape prism(double length, double width, double height) {
  std::vector<Vec3> points;
  for (double x : {-0.5 * length, 0.5 * length}) {
    points.emplace_back(x, -height / 3.0, -0.5 * width);
    points.emplace_back(x, -height / 3.0, 0.5 * width);
    points.emplace_back(x, 2.0 * height / 3.0, 0.0);
  }
  return Shape::convex_hull(std::move(points));
}

}  // namespace

Scene make_big_bodies(const SceneParams& params) {
  Scene scene = start_scene("big-bodies", params);
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultBigBodiesCubes;
  // Unit cubes on a square grid 1.6 m apart, in layers 1.6 m apart from
  // y = 1 m: a loose block the big bodies fall into.
  const int side = static_cast<int>(std::ceil(std::sqrt(n / 3.0)));
  const double half = 0.8 * side;
  scene.bodies.push_back(flat_ground(half + 24.0, 0.5));
  BodyId id = 1;
  for (int i = 0; i < n; ++i) {
    const int layer = i / (side * side), row = (i / side) % side, col = i % side;
    const Vec3 at(-half + 0.8 + 1.6 * col, 1.0 + 1.6 * layer, -half + 0.8 + 1.6 * row);
    scene.bodies.push_back(dynamic_box(id++, Vec3::Constant(0.5), 1.0, at, rng.rotation()));
  }
  // Above the block, each over a different part of it (so across borders),
  // in three tiers by size: 2 m, 5 m, then 20 m across. Masses: 5 kg per
  // cubic metre of bounding box (the beam 100 kg on 1 kg cubes: a mass ratio
  // the solver holds in both precisions; 500 kg/m³ pushed a cube 1.2 m into
  // the ground under the 20 m prism in double precision).
  const double top = 1.0 + 1.6 * ((n - 1) / (side * side)) + 3.0;
  auto add = [&](Shape shape, const Vec3& at, const Quat& q) {
    Body b;
    b.id = id++;
    b.shape = std::move(shape);
    const Vec3 e = 2.0 * b.shape.local_half_extents();
    b.mass = 5.0 * e.x() * e.y() * e.z();
    b.position = at;
    b.orientation = q;
    scene.bodies.push_back(std::move(b));
  };
  const Quat tilt(Eigen::AngleAxisd(0.3, Vec3(0.3, 1.0, 0.2).normalized()));
  add(Shape::box(Vec3(1.0, 1.0, 1.0)), Vec3(-0.5 * half, top + 1.5, -0.5 * half), tilt);
  add(Shape::capsule(0.5, 1.0), Vec3(0.5 * half, top + 1.5, -0.5 * half), tilt);
  add(prism(2.0, 1.2, 1.2), Vec3(0.0, top + 1.5, 0.5 * half), tilt);
  add(Shape::box(Vec3(2.5, 0.15, 0.5)), Vec3(-0.4 * half, top + 5.0, 0.3 * half), tilt);  // a 5 m plank
  add(Shape::capsule(0.4, 4.2), Vec3(0.4 * half, top + 5.0, 0.3 * half), tilt);
  add(prism(5.0, 1.0, 1.0), Vec3(0.0, top + 5.0, -0.3 * half), tilt);
  add(Shape::box(Vec3(10.0, 0.25, 1.0)), Vec3(0.0, top + 9.0, 0.1 * half), tilt);  // a 20 m beam
  add(prism(20.0, 1.5, 1.5), Vec3(0.0, top + 12.0, -0.1 * half), tilt.conjugate());
  return scene;
}

Scene make_plank_pile(const SceneParams& params) {
  Scene scene = start_scene("plank-pile", params);
  const int length = count_or_default(params, 8, 40);  // the plank, m
  // A pile of 4 x 4 unit cubes, 3 layers, faces touching (1 kg each); a
  // plank `length` x 0.2 x 0.6 m of 40 kg across its top, 0.5 m above it,
  // turned 30 degrees about y and tilted 0.05 rad so that it lands end
  // first.
  scene.bodies.push_back(flat_ground(0.5 * length + 10.0, 0.5));
  BodyId id = 1;
  for (int layer = 0; layer < 3; ++layer)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        scene.bodies.push_back(
            dynamic_box(id++, Vec3::Constant(0.5), 1.0, Vec3(-1.5 + i, 0.5 + layer, -1.5 + j)));
  const Quat turn = Quat(Eigen::AngleAxisd(0.52, Vec3::UnitY())) * Quat(Eigen::AngleAxisd(0.05, Vec3::UnitZ()));
  scene.bodies.push_back(dynamic_box(id++, Vec3(0.5 * length, 0.1, 0.3), 40.0, Vec3(0.0, 3.6, 0.0), turn));
  return scene;
}

Scene make_heavy_slide(const SceneParams& params) {
  Scene scene = start_scene("heavy-slide", params);
  const int speed = magnitude_or_default(params, 6);  // m/s along +x
  // A 5 m box of 10 t on a long ground, both of friction 0.4 (Bullet
  // combines them as their product, 0.16), starting at x = -12 m at `speed`
  // m/s: it slides across the borders of grid:Kx1x1 over its path. Two rows
  // of unit cubes stand in its path from x = -12 + v^2 / (2 * 0.4 * g) + 1
  // (-6.4 m at 6 m/s); it pushes them ahead until friction stops it (near
  // x = -0.7 m at 6 m/s).
  Body ground = flat_ground(60.0, 0.4);
  scene.bodies.push_back(ground);
  Body box = dynamic_box(1, Vec3::Constant(2.5), 10000.0, Vec3(-12.0, 2.5, 0.0));
  box.friction = 0.4;
  box.linear_velocity = Vec3(speed, 0, 0);
  scene.bodies.push_back(box);
  BodyId id = 2;
  const double stop = -12.0 + double(speed) * speed / (2 * 0.4 * 9.81);
  for (int row = 0; row < 2; ++row)
    for (int k = -2; k <= 2; ++k)
      scene.bodies.push_back(dynamic_box(id++, Vec3::Constant(0.5), 1.0, Vec3(stop + 1.0 + 1.2 * row, 0.5, 1.2 * k)));
  return scene;
}

}  // namespace soda::detail

