// Speculation (PartitionedOptions::anticipation, docs/rollback.md): worlds
// bet on empty neighbour messages and run ahead; lost bets and changed
// messages are repaired by Rollback and Propagate. Every run must end on the
// one-territory hash, whatever the anticipation, schedule, fuzzing or
// rollback mode. Label "concurrency" (ThreadSanitizer in CI).
#include "runtime/partitioned_test_util.h"

#include <chrono>
#include <map>
#include <thread>

namespace soda {
namespace {

constexpr int kSteps = 60;

struct Case {
  const char* scene;
  int n;
  const char* partition;
  int territories;
  bool border_grid;
};

GridOptions grid_of(const Case& c) {
  GridOptions g;
  if (c.border_grid) {
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    if (std::string(c.scene) == "chain") g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  }
  return g;
}

const std::vector<Case>& cases() {
  static const std::vector<Case> all = {
      {"falling-cubes", 150, "kmeans", 4, false}, {"cube-pile", 150, "rcb", 3, false},
      {"seam-stack", 0, "grid:2x1x2", 4, true},   {"cross-traffic", 0, "grid:2x1x2", 4, true},
      {"projectile", 0, "kmeans", 8, true},       {"chain", 16, "grid:8x1x1", 8, true},
  };
  return all;
}

std::uint64_t reference(const Case& c) {
  static std::map<std::string, std::uint64_t> cache;
  auto it = cache.find(c.scene);
  if (it == cache.end()) it = cache.emplace(c.scene, test::reference_hash(test::scene(c.scene, c.n), kSteps)).first;
  return it->second;
}

WorldMetrics totals(const PartitionedWorld& w) { return total_metrics(w.metrics()); }

// Every scene, anticipation 0, 1, 8 and 64, sequential and a thread per
// world: the one-territory hash.
TEST(Speculation, EveryAnticipationMatchesOneTerritory) {
  for (const Case& c : cases())
    for (int anticipation : {0, 1, 8, 64})
      for (Schedule schedule : {Schedule::Sequential, Schedule::ThreadPerWorld}) {
        const Scene s = test::scene(c.scene, c.n);
        PartitionedOptions o;
        o.schedule = schedule;
        o.anticipation = anticipation;
        o.validate = true;
        PartitionedWorld world(s, make_partition(c.partition, s, c.territories, grid_of(c)), o);
        world.step(kSteps);
        const WorldMetrics t = totals(world);
        std::printf("%-14s K=%d anticipation %2d %-16s: %4llu bets, %3llu lost, %3llu rollbacks, lead max %lld\n",
                    c.scene, c.territories, anticipation, schedule_name(schedule), (unsigned long long)t.bets,
                    (unsigned long long)t.bets_lost, (unsigned long long)t.rollbacks, (long long)t.lead_max);
        EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(reference(c)))
            << c.scene << " K=" << c.territories << " anticipation " << anticipation << " "
            << schedule_name(schedule) << ": " << t.bets << " bets, " << t.rollbacks << " rollbacks";
        if (anticipation == 0) {
          EXPECT_EQ(t.bets, 0u);
        }
      }
}

}  // namespace
}  // namespace soda
