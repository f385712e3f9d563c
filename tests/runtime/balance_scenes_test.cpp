// Every load scene (hotspot, avalanche, rain, drift; docs/scenes.md) under every
// balance policy (none, diffusive, rcb, churn) for K = 2, 4, 8, with
// anticipation 0 and 8, SyncTest and validation on, ends on the one-territory
// hash: load balancing decides speed, never physics (#15, acceptance 1).
#include <map>
#include <mutex>

#include "runtime/partitioned_test_util.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

constexpr int kN = 64;
constexpr int kSteps = 90;
constexpr int kPeriod = 10;

SceneParams params() { return SceneParams{kN, 1, false}; }

PartitionedOptions options(const std::string& scene) {
  PartitionedOptions o;
  o.validate = true;
  o.inputs = scene_inputs(scene, params());  // rain's later waves; empty for the others
  return o;
}

// One territory, no balancing, computed once per scene.
std::uint64_t one_territory(const std::string& scene) {
  static std::mutex mutex;
  static std::map<std::string, std::uint64_t> hashes;
  const std::lock_guard lock(mutex);
  auto it = hashes.find(scene);
  if (it != hashes.end()) return it->second;
  const Scene s = make_scene(scene, params());
  PartitionedWorld one(s, make_partition("kmeans", s, 1, GridOptions{}), options(scene));
  one.step(kSteps);
  return hashes[scene] = one.state_hash();
}

struct Case {
  const char* scene;
  const char* policy;
  int territories;
  int anticipation;
};

class LoadSceneBalance : public ::testing::TestWithParam<Case> {};

TEST_P(LoadSceneBalance, HashEqualsOneTerritory) {
  const Case c = GetParam();
  const Scene s = make_scene(c.scene, params());
  const TerritoryMap map =
      make_partition("grid:" + std::to_string(c.territories) + "x1x1", s, c.territories, GridOptions{});
  PartitionedOptions o = options(c.scene);
  o.schedule = Schedule::ThreadPerWorld;
  o.anticipation = c.anticipation;
  o.sync_test = 1;
  o.balance.policy = c.policy;
  o.balance.period = kPeriod;
  o.balance.seed = 3;
  PartitionedWorld world(s, map, o);
  world.step(kSteps);
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(one_territory(c.scene)));
  EXPECT_EQ(world.sync_rollbacks(), static_cast<std::uint64_t>(kSteps));
  const BalanceTotals t = balance_totals(world.balance_log());
  if (std::string(c.policy) == "none") {
    EXPECT_EQ(t.balance_steps, 0);
  } else {
    EXPECT_EQ(t.balance_steps, (kSteps - 1) / kPeriod);
  }
  // A measuring policy records how well its cost model predicted each period
  // (from its second balance step: the first has nothing measured before it).
  int predicted = 0;
  for (const BalanceRecord& r : world.balance_log()) predicted += r.prediction.samples > 0 ? 1 : 0;
  if (std::string(c.policy) == "churn") {
    EXPECT_GT(t.cells_moved, 0);
    EXPECT_GT(t.bodies_moved, 0);
    EXPECT_EQ(predicted, 0);  // churn has no model
  } else if (std::string(c.policy) != "none") {
    EXPECT_GE(predicted, t.balance_steps - 1);
  }
}

std::vector<Case> cases() {
  std::vector<Case> out;
#ifdef __SANITIZE_THREAD__
  // ThreadSanitizer looks for races, not for hashes: each policy once on
  // four threads with speculation (the Release build runs the whole matrix;
  // 42 cases under TSan cost about 7 minutes of CI).
  for (const char* policy : {"diffusive", "rcb", "churn"}) out.push_back({"hotspot", policy, 4, 8});
  out.push_back({"rain", "churn", 8, 0});
  return out;
#endif
  // The whole matrix: every load scene, every policy, K = 2, 4, 8,
  // each with anticipation 0 and 8 (72 cases, about 0.4 s each).
  for (const char* scene : {"hotspot", "avalanche", "rain"})
    for (const char* policy : {"none", "diffusive", "rcb", "churn"})
      for (int k : {2, 4, 8})
        for (int anticipation : {0, 8}) out.push_back({scene, policy, k, anticipation});
  // drift, the 2-world benchmark's scene
  for (const char* policy : {"diffusive", "rcb", "churn"}) out.push_back({"drift", policy, 2, 0});
  out.push_back({"drift", "diffusive", 4, 8});
  return out;
}

INSTANTIATE_TEST_SUITE_P(Runtime, LoadSceneBalance, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::string(info.param.scene) + "_" + info.param.policy + "_K" +
                                  std::to_string(info.param.territories) + "_a" +
                                  std::to_string(info.param.anticipation);
                         });

}  // namespace
}  // namespace soda
