// Stacks that stand at the defaults (#17): the canonical world's friction
// directions and per-island iterations (worlds/src/island_solver_settings.h)
// keep a 30-box tower, a 1000:1 mass ratio and a 100 kg box dropped on a
// tower of ten 1 kg boxes standing at 1/60 s and 10
// iterations, and the iterations an island gets are a function of its
// contents alone — so the same stacks cut by territory borders (border
// islands solved by several worlds, docs/partitioned-step.md) give the
// one-world hash bit for bit.
#include <cmath>

#include "runtime/partitioned_test_util.h"

namespace soda {
namespace {

using test::border_grid;

// Largest distance any dynamic body moved from where it started.
double max_displacement(const Scene& s, const std::vector<BodyState>& end) {
  double worst = 0;
  for (const BodyState& b : end)
    for (const Body& d : s.bodies)
      if (d.id == b.id && !d.is_static) {
        const Vec3 p(double(b.origin[0]), double(b.origin[1]), double(b.origin[2]));
        worst = std::max(worst, (p - d.position).norm());
      }
  return worst;
}

// The heavy-drop scene's check (the stress suite's): no tower box moves more
// than 0.1 m sideways, the heavy box (the last id) ends on top.
void expect_heavy_box_on_top(const Scene& s, const std::vector<BodyState>& end) {
  double sideways = 0, heavy_y = 0;
  for (const BodyState& b : end)
    for (const Body& d : s.bodies)
      if (d.id == b.id && !d.is_static) {
        if (b.id == s.bodies.back().id) {
          heavy_y = double(b.origin[1]);
          continue;
        }
        sideways = std::max(sideways, std::hypot(double(b.origin[0]) - d.position.x(), double(b.origin[2]) - d.position.z()));
      }
  std::printf("  tower boxes moved sideways at most %.4g m, heavy box at y %.4g m\n", sideways, heavy_y);
  EXPECT_LT(sideways, 0.1);
  EXPECT_NEAR(heavy_y, 10.5, 0.1);
}

void expect_stands_on_every_map(const std::string& name, int n, int steps) {
  const Scene s = test::scene(name, n);
  CanonicalWorld one(s);
  for (int i = 0; i < steps; ++i) one.step();
  const double moved = max_displacement(s, one.body_states());
  std::printf("[ %s n=%d %s ] %d steps: max displacement %.4g m, hash %s\n", name.c_str(), n, kPrecisionName, steps,
              moved, hash_hex(one.state_hash()).c_str());
  if (name == "heavy-drop")
    expect_heavy_box_on_top(s, one.body_states());
  else
    EXPECT_LT(moved, 0.1) << name << " " << n;  // the stress suite's "stands"
  // The stack on the corner of four territories (a border island over four
  // worlds), then cut along its height.
  for (const auto& [partition, k] : {std::pair<std::string, int>{"grid:2x1x2", 4}, {"grid:1x4x1", 4}}) {
    const TerritoryMap map = make_partition(partition, s, k, border_grid());
    PartitionedWorld world(s, map, PartitionedOptions{.runtime = {.validate = true}});
    world.step(steps);
    EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(one.state_hash())) << name << " " << partition;
    if (world.state_hash() != one.state_hash()) ADD_FAILURE() << test::first_divergence(s, map, steps);
    if (partition == "grid:2x1x2") {  // the corner: solved as border islands over four worlds
      EXPECT_GT(test::total(world.metrics()).merged_islands, 0u) << name;
    }
  }
}

TEST(StableStacks, ThirtyBoxTowerStandsOnEveryMap) { expect_stands_on_every_map("tower", 30, 240); }

TEST(StableStacks, ThousandToOneMassRatioStandsOnEveryMap) { expect_stands_on_every_map("mass-ratio", 1000, 240); }

// A stiff island (tall and heavy-on-light: 1000 iterations, split impulse for
// every penetration): the 100 kg box lands at step 28 and stays on top.
TEST(StableStacks, HeavyBoxDroppedOnTowerStaysOnTopOnEveryMap) { expect_stands_on_every_map("heavy-drop", 10, 90); }

}  // namespace
}  // namespace soda
