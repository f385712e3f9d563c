// big-bodies: bodies of 2 m, 5 m and 20 m across (boxes, capsules, convex
// hulls) falling among unit cubes onto a static ground, crossing territory
// borders: the scene of docs/determinism.md, "Bodies of any size".
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultCubes = 300;

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
  const int n = params.n > 0 ? params.n : kDefaultCubes;
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
  // in three tiers by size: 2 m, 5 m, then 20 m across. Masses: 500 kg per
  // cubic metre of bounding box, so heavy bodies on light cubes.
  const double top = 1.0 + 1.6 * ((n - 1) / (side * side)) + 3.0;
  auto add = [&](Shape shape, const Vec3& at, const Quat& q) {
    Body b;
    b.id = id++;
    b.shape = std::move(shape);
    const Vec3 e = 2.0 * b.shape.local_half_extents();
    b.mass = 500.0 * e.x() * e.y() * e.z();
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

}  // namespace soda::detail
