// sleepers: many bodies asleep on the ground, a few active ones falling
// onto part of them: what a scene costs when most of it sleeps
// (docs/scenes.md, `soda bench sleepers`).
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultSleepers = 100000;
// One active cube per this many sleepers: 1,000 for the default 100,000.
constexpr int kSleepersPerActive = 100;
// Sleepers each exactly resting on the ground (centre at y = 0.5 m); the
// active cubes over the middle of the field land on sleepers and wake them
// (spacings: generators.h).

}  // namespace

int sleepers_active_count(int sleepers) { return (sleepers + kSleepersPerActive - 1) / kSleepersPerActive; }

Scene make_sleepers(const SceneParams& params) {
  Scene scene;
  scene.name = "sleepers";
  scene.seed = params.seed;
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultSleepers;
  const int active = sleepers_active_count(n);
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  const double offset = 0.5 * kSleeperSpacing * (side - 1);

  scene.bodies.push_back(flat_ground(offset + kGroundMargin, 0.5));
  scene.bodies.reserve(static_cast<std::size_t>(n + active + 1));
  BodyId id = 1;
  for (int i = 0; i < n; ++i) {
    const Vec3 p((i / side) * kSleeperSpacing - offset, 0.5, (i % side) * kSleeperSpacing - offset);
    Body b = dynamic_box(id++, Vec3::Constant(0.5), 1.0, p);
    b.asleep = true;
    scene.bodies.push_back(b);
  }
  const int columns = static_cast<int>(std::ceil(std::sqrt(active / static_cast<double>(kActiveLayers))));
  const double active_offset = 0.5 * kActiveSpacing * (columns - 1);
  int placed = 0;
  for (int layer = 0; placed < active; ++layer)
    for (int ix = 0; ix < columns && placed < active; ++ix)
      for (int iz = 0; iz < columns && placed < active; ++iz, ++placed) {
        const Vec3 p(ix * kActiveSpacing - active_offset, kFirstActiveY + layer * kActiveSpacing,
                     iz * kActiveSpacing - active_offset);
        scene.bodies.push_back(dynamic_box(id++, Vec3::Constant(0.5), 1.0, p, rng.rotation()));
      }
  return scene;
}

}  // namespace soda::detail
