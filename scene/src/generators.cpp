#include "generators.h"

#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "random.h"
#include "soda/scene/validate.h"

namespace soda::detail {
namespace {

// Ground: a static box whose top face is at y = 0 (kGroundMargin: generators.h).
constexpr double kGroundHalfThickness = 0.5;

Body make_ground(double half_footprint) {
  Body g;
  g.id = kGroundId;
  g.is_static = true;
  const double h = half_footprint + kGroundMargin;
  g.shape = Shape::box(Vec3(h, kGroundHalfThickness, h));
  g.mass = 0.0;
  g.friction = 0.5;
  g.position = Vec3(0.0, -kGroundHalfThickness, 0.0);
  return g;
}

Body make_cube(BodyId id, double edge, const Vec3& position, const Quat& orientation) {
  Body c;
  c.id = id;
  c.shape = Shape::box(Vec3::Constant(0.5 * edge));
  c.mass = edge * edge * edge;  // 1 kg for the unit cube, same density for all
  c.friction = 0.5;
  c.restitution = 0.0;
  c.position = position;
  c.orientation = orientation;
  return c;
}

// falling-cubes and cube-pile: n = 0 means this many cubes.
constexpr int kDefaultCubes = 1000;

}  // namespace

Scene make_falling_cubes(const SceneParams& params) {
  Scene scene;
  scene.name = "falling-cubes";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultCubes;
  const double footprint = 2.0 * std::sqrt(static_cast<double>(n));
  const double half = 0.5 * footprint;
  scene.bodies.push_back(make_ground(half));

  // Rejection sampling on bounding spheres. Cubes occupy ~3 % of the volume
  // (L^2 * 20 m = 80 N m^3), so a try is almost always accepted; a spatial
  // hash keeps it linear.
  constexpr double kMaxEdge = 1.3;
  const double hash_cell = kMaxEdge * std::sqrt(3.0);
  std::unordered_map<std::int64_t, std::vector<int>> buckets;
  auto key = [&](int ix, int iy, int iz) {
    return (static_cast<std::int64_t>(ix) * 73856093) ^ (static_cast<std::int64_t>(iy) * 19349663) ^
           (static_cast<std::int64_t>(iz) * 83492791);
  };
  std::vector<double> radius;
  for (int i = 0; i < n; ++i) {
    const double edge = params.random_scale ? rng.uniform(0.2, kMaxEdge) : 1.0;
    const double r = 0.5 * std::sqrt(3.0) * edge;
    const Quat q = rng.rotation();
    for (int attempt = 0;; ++attempt) {
      if (attempt > 100000)
        throw SceneError("falling-cubes: could not place cube " + std::to_string(i) +
                         " without overlap");
      const Vec3 p(rng.uniform(-half, half), rng.uniform(1.0, 21.0), rng.uniform(-half, half));
      const int cx = static_cast<int>(std::floor(p.x() / hash_cell));
      const int cy = static_cast<int>(std::floor(p.y() / hash_cell));
      const int cz = static_cast<int>(std::floor(p.z() / hash_cell));
      bool overlaps = false;
      for (int dx = -1; dx <= 1 && !overlaps; ++dx)
        for (int dy = -1; dy <= 1 && !overlaps; ++dy)
          for (int dz = -1; dz <= 1 && !overlaps; ++dz) {
            auto it = buckets.find(key(cx + dx, cy + dy, cz + dz));
            if (it == buckets.end()) continue;
            for (int j : it->second) {
              const Body& other = scene.bodies[static_cast<std::size_t>(j) + 1];
              const double min_d = r + radius[static_cast<std::size_t>(j)];
              if ((other.position - p).squaredNorm() < min_d * min_d) {
                overlaps = true;
                break;
              }
            }
          }
      if (overlaps) continue;
      buckets[key(cx, cy, cz)].push_back(i);
      radius.push_back(r);
      scene.bodies.push_back(make_cube(static_cast<BodyId>(i + 1), edge, p, q));
      break;
    }
  }
  return scene;
}

namespace {

// cube-pile and heap: columns `spacing` m apart in x and z centred on the
// origin, kColumnLayers layers `spacing` m apart from y = kFirstLayerY.
constexpr int kColumnLayers = 10;
constexpr double kFirstLayerY = 2.0;

Scene make_cube_columns(const SceneParams& params, const char* name, double spacing) {
  Scene scene;
  scene.name = name;
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultCubes;
  const int side = static_cast<int>(std::ceil(std::sqrt(n / static_cast<double>(kColumnLayers))));
  const double offset = 0.5 * spacing * (side - 1);  // centres the columns on the origin
  scene.bodies.push_back(make_ground(offset + spacing));
  // Layer by layer from the bottom, row-major within a layer; the top layer
  // is partial when n is not a multiple of side^2.
  int placed = 0;
  for (int layer = 0; placed < n; ++layer) {
    for (int ix = 0; ix < side && placed < n; ++ix)
      for (int iz = 0; iz < side && placed < n; ++iz) {
        const Vec3 p(ix * spacing - offset, kFirstLayerY + layer * spacing, iz * spacing - offset);
        scene.bodies.push_back(make_cube(static_cast<BodyId>(placed + 1), 1.0, p, rng.rotation()));
        ++placed;
      }
  }
  return scene;
}

}  // namespace

Scene make_cube_pile(const SceneParams& params) {
  // 1.5 m: rotated unit cubes (reach 0.87 m) may start interpenetrating; part
  // of the scene's definition (BENCHMARKS.md), kept for comparability.
  constexpr double kSpacing = 1.5;
  return make_cube_columns(params, "cube-pile", kSpacing);
}

Scene make_heap(const SceneParams& params) {
  // 1.8 m > sqrt(3): two unit cubes whose centres are this far apart cannot
  // touch in any orientation, so the heap starts without overlaps.
  constexpr double kSpacing = 1.8;
  return make_cube_columns(params, "heap", kSpacing);
}

}  // namespace soda::detail
