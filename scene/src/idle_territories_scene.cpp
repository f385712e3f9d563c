// idle-territories: eight regions along x, cut grid:8x1x1 into eight
// territories; activity in the first only (docs/scenes.md, `soda bench
// idle-territories`, docs/skip.md "Idle territories").
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultPerRegion = 200;
constexpr int kRegions = 8;
// Sleepers and active cubes spaced as in the sleepers scene (generators.h).
// Empty ground between the regions' bodies: wider than a grid slab's
// rounding (a cell of about 1.7 m) plus where a falling pile spreads, so
// that no body of one region comes near another region's territory.
constexpr double kRegionGap = 16.0;

}  // namespace

Scene make_idle_territories(const SceneParams& params) {
  Scene scene;
  scene.name = "idle-territories";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultPerRegion;
  const int columns = static_cast<int>(std::ceil(std::sqrt(n / static_cast<double>(kActiveLayers))));
  // Every region spans along x what the active columns span (sleepers in
  // rows along z): eight regions of one x-extent, so that grid:8x1x1's equal
  // slabs of the bodies' box fall in the gaps. (Sleepers in a square wider
  // than the pile made the box's slabs narrower than the regions' pitch:
  // the borders 0|1 and 1|2 then cut through regions 1 and 2's sleepers,
  // ghosted every step, and worlds 1 and 2 never idled.)
  const double extent = (columns - 1) * kActiveSpacing;
  const int sleeper_columns = static_cast<int>(std::floor(extent / kSleeperSpacing)) + 1;
  const int sleeper_rows = (n + sleeper_columns - 1) / sleeper_columns;
  const double width = extent + 1.0 + kRegionGap;
  const double first_centre = -0.5 * width * (kRegions - 1);
  scene.bodies.push_back(flat_ground(0.5 * width * kRegions + kGroundMargin, 0.5));
  scene.bodies.reserve(static_cast<std::size_t>(kRegions * n + 1));
  BodyId id = 1;
  // Region 0: n active cubes falling onto the bare ground.
  const double active_offset = 0.5 * kActiveSpacing * (columns - 1);
  int placed = 0;
  for (int layer = 0; placed < n; ++layer)
    for (int ix = 0; ix < columns && placed < n; ++ix)
      for (int iz = 0; iz < columns && placed < n; ++iz, ++placed) {
        const Vec3 p(first_centre + ix * kActiveSpacing - active_offset, kFirstActiveY + layer * kActiveSpacing,
                     iz * kActiveSpacing - active_offset);
        scene.bodies.push_back(dynamic_box(id++, Vec3::Constant(0.5), 1.0, p, rng.rotation()));
      }
  // Regions 1..7: n sleepers each (Body::asleep), rows along z.
  const double sleeper_x_offset = 0.5 * kSleeperSpacing * (sleeper_columns - 1);
  const double sleeper_z_offset = 0.5 * kSleeperSpacing * (sleeper_rows - 1);
  for (int r = 1; r < kRegions; ++r)
    for (int i = 0; i < n; ++i) {
      const Vec3 p(first_centre + r * width + (i % sleeper_columns) * kSleeperSpacing - sleeper_x_offset, 0.5,
                   (i / sleeper_columns) * kSleeperSpacing - sleeper_z_offset);
      Body b = dynamic_box(id++, Vec3::Constant(0.5), 1.0, p);
      b.asleep = true;
      scene.bodies.push_back(b);
    }
  return scene;
}

}  // namespace soda::detail
