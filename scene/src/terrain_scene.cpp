// terrain (docs/scenes.md): boulders, balls and boxes rolling down a valley
// of a static heightfield (docs/scene-format.md, "Triangle meshes and
// heightfields") across territory borders.
#include <algorithm>
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultBodies = 200;
constexpr double kSample = 0.5;   // m between heightfield samples
constexpr double kBodyPitch = 1.6;    // m between bodies at the start (the largest is 1.2 m across)

// The valley's height at (x, z): a basin along x (steep at the high end
// x = -length, lowest at x = 0.6 length), walls along z, bumps.
double valley(double x, double z, double length, double half_width, double scale) {
  const double u = x / length - 0.6, w = z / half_width;
  return 14.0 * scale * u * u + 8.0 * scale * w * w + 0.3 * std::sin(0.7 * x) * std::cos(0.5 * z);
}

Shape boulder(SceneRandom& rng, double radius) {
  std::vector<Vec3> points;
  for (int i = 0; i < 10; ++i) {
    const Vec3 d = rng.rotation() * Vec3::UnitX();
    points.push_back(d * radius * rng.uniform(0.8, 1.0));
  }
  return Shape::convex_hull(std::move(points));
}

}  // namespace

Scene make_terrain(const SceneParams& params) {
  Scene scene = start_scene("terrain", params);
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultBodies;
  const double scale = std::max(1.0, std::sqrt(n / double(kDefaultBodies)));
  const double length = 40.0 * scale, half_width = 20.0 * scale;  // the heightfield spans [-length, length] x [-half_width, half_width]
  auto hf = std::make_shared<HeightfieldData>();
  hf->columns = static_cast<int>(std::lround(2.0 * length / kSample)) + 1;
  hf->rows = static_cast<int>(std::lround(2.0 * half_width / kSample)) + 1;
  hf->spacing = Vec3(kSample, 1.0, kSample);
  hf->heights.reserve(static_cast<std::size_t>(hf->columns) * static_cast<std::size_t>(hf->rows));
  for (int j = 0; j < hf->rows; ++j)
    for (int i = 0; i < hf->columns; ++i)
      hf->heights.push_back(valley((i - (hf->columns - 1) / 2) * kSample, (j - (hf->rows - 1) / 2) * kSample, length,
                                   half_width, scale));
  Body ground;
  ground.id = 0;
  ground.is_static = true;
  ground.friction = 0.8;
  ground.shape = Shape::heightfield_of(std::move(hf));
  scene.bodies.push_back(std::move(ground));
  // A block of bodies on the high slope: rows across the valley, columns
  // down it, layers above, each body 1 m above the surface under it.
  const int across = std::max(1, static_cast<int>(0.6 * 2.0 * half_width / kBodyPitch));
  const int down = std::max(1, static_cast<int>(0.8 * length / kBodyPitch));
  for (int i = 0; i < n; ++i) {
    const int layer = i / (across * down), col = (i / across) % down, row = i % across;
    const double x = -0.9 * length + kBodyPitch * (col + 0.5), z = kBodyPitch * (row - 0.5 * (across - 1));
    Body b;
    b.id = static_cast<BodyId>(i + 1);
    b.friction = 0.6;
    const int kind = static_cast<int>(rng.unit() * 3.0);
    const double size = rng.uniform(0.35, 0.6);
    if (kind == 0) {
      b.shape = boulder(rng, size);
    } else if (kind == 1) {
      b.shape = Shape::sphere(size);
    } else {
      b.shape = Shape::box(Vec3(size, 0.8 * size, 0.9 * size));
    }
    b.mass = 20.0 * size * size * size;
    b.position = Vec3(x, valley(x, z, length, half_width, scale) + 1.0 + size + kBodyPitch * layer, z);
    b.orientation = rng.rotation();
    scene.bodies.push_back(std::move(b));
  }
  return scene;
}

}  // namespace soda::detail
