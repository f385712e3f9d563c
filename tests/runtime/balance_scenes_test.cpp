// Every load scene (hotspot, avalanche, rain, drift; docs/scenes.md) under every
// balance policy (none, diffusive, rcb, churn) for K = 2, 4, 8, with
// anticipation 0 and 8, SyncTest and validation on, ends on the one-territory
// hash: load balancing decides speed, never physics. Every policy but none
// moves cells in every case, so the hash check covers real cessions.
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>

#include "runtime/partitioned_test_util.h"
#include "soda/loadbalance/policy.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

constexpr int kN = 64;
constexpr int kSteps = 90;
constexpr int kPeriod = 10;

SceneParams params() { return SceneParams{kN, 1, false}; }

PartitionedOptions options(const std::string& scene) {
  PartitionedOptions o;
  o.runtime.validate = true;
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

// The policy named, deciding on a load that is a function of the scene's
// state instead of the threads' measured CPU time: each world's busy time
// is its awake bodies plus its contact pairs (10 us each). Measured time on
// a loaded machine decides differently from run to run (a light scene such
// as rain 64 moved no cell in some runs), so the cells a policy moves, and
// what this test can ask of them, would depend on the machine's minute.
// The measured path is balance_test.cpp's and `soda lb`'s.
class CountedLoad : public BalancePolicy {
 public:
  explicit CountedLoad(const BalanceOptions& o) : inner_(make_balance_policy(o)) {}
  const char* name() const override { return inner_->name(); }
  std::vector<CellMove> decide(const LoadView& view) override {
    LoadView counted = view;
    for (WorldLoad& w : counted.worlds) w.busy = 1e-5 * static_cast<double>(w.awake_bodies + w.contact_pairs);
    return inner_->decide(counted);
  }
  const LoadMonitor* monitor() const override { return inner_->monitor(); }

 private:
  std::unique_ptr<BalancePolicy> inner_;
};

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
  // Slabs along x; rain's across its height (its drops fall through every
  // territory and pile up in the lowest: a load that moves, where slabs
  // along x share the rain evenly and leave rcb nothing to gain at K = 8).
  const std::string k = std::to_string(c.territories);
  const std::string grid = std::string(c.scene) == "rain" ? "grid:1x" + k + "x1" : "grid:" + k + "x1x1";
  const TerritoryMap map = make_partition(grid, s, c.territories, GridOptions{});
  PartitionedOptions o = options(c.scene);
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.anticipation = c.anticipation;
  o.sync_test = 1;
  o.runtime.balance.policy = c.policy;
  o.runtime.balance.period = kPeriod;
  o.runtime.balance.seed = 3;
  if (std::string(c.policy) != "none") o.balance_policy = std::make_shared<CountedLoad>(o.runtime.balance);
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
  std::printf("[ %s %s K=%d a=%d ] %lld balance steps, %lld cells and %lld bodies moved\n", c.scene, c.policy,
              c.territories, c.anticipation, static_cast<long long>(t.balance_steps),
              static_cast<long long>(t.cells_moved), static_cast<long long>(t.bodies_moved));
  if (std::string(c.policy) == "none") {
    EXPECT_EQ(t.cells_moved, 0);
  } else {
    // Every policy that balances moves cells in every case (each load scene
    // starts with its load on a few worlds): a policy that moved nothing
    // would pass the hash check above without testing the cession.
    EXPECT_GT(t.cells_moved, 0) << c.policy << " moved no cell";
  }
  if (std::string(c.policy) == "churn") {
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
