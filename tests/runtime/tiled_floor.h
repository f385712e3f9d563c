// A scene's ground cut into a floor of static tiles, for the suites that
// check which statics a territory world holds (worlds/src/static_catalog.h).
#pragma once

#include <cmath>

#include "soda/scene/scene.h"
#include "soda/scene/validate.h"

namespace soda::test {

/// `s` with its ground (the first body, a static box) cut into square tiles
/// `pitch` m apart, each 0.1 m larger than its pitch (no gaps) and tilted by
/// up to 2 degrees; the first tile keeps the ground's id, the others take
/// ids after the scene's last.
inline Scene tiled_floor(Scene s, double pitch) {
  const Body ground = s.bodies.front();
  s.bodies.erase(s.bodies.begin());
  const int n = static_cast<int>(std::ceil(2.0 * ground.shape.half_extents.x() / pitch));
  const double start = -0.5 * n * pitch;
  BodyId next = static_cast<BodyId>(s.bodies.size()) + 1;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      Body t = ground;
      t.id = i == 0 && j == 0 ? ground.id : next++;
      t.shape = Shape::box(Vec3(0.5 * pitch + 0.05, 0.25, 0.5 * pitch + 0.05));
      t.position = Vec3(start + (i + 0.5) * pitch, -0.25, start + (j + 0.5) * pitch);
      const double ax = 0.035 * std::sin(1.7 * i + 2.3 * j), az = 0.035 * std::cos(2.9 * i + 1.1 * j);
      t.orientation = Quat(Eigen::AngleAxisd(ax, Vec3::UnitX()) * Eigen::AngleAxisd(az, Vec3::UnitZ()));
      s.bodies.push_back(t);
    }
  validate_scene(s, "tiled floor", Precision::Float);
  return s;
}

}  // namespace soda::test
