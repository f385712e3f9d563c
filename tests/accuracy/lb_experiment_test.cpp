// soda lb's experiment: every policy ends on one hash, the files it writes
// hold what they claim, imbalance is computed as documented.
#include "soda/bench/lb_experiment.h"

#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

StepLoads step_of(std::int64_t step, std::initializer_list<double> busy_ms) {
  StepLoads s;
  s.step = step;
  for (double b : busy_ms) s.worlds.push_back(WorldStepLoad{.busy_seconds = b * 1e-3});
  return s;
}

TEST(LbImbalance, IsMaxOverMeanPerStepAndSkipsIdleSteps) {
  const std::vector<StepLoads> loads = {step_of(1, {3, 1}), step_of(2, {0, 0}), step_of(3, {2, 2})};
  const Imbalance im = imbalance_of(loads);
  EXPECT_EQ(im.steps, 2);
  EXPECT_DOUBLE_EQ(im.mean, (1.5 + 1.0) / 2);  // step 1: 3 / 2; step 3: 2 / 2
  EXPECT_DOUBLE_EQ(im.max, 1.5);
  EXPECT_DOUBLE_EQ(im.weighted, (3.0 + 2.0) / (2.0 + 2.0));
}

std::size_t lines(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

TEST(LbExperiment, EveryPolicyEndsOnOneHashAndTheFilesHoldEveryStep) {
  const Scene scene = make_scene("falling-cubes", {.n = 150, .seed = 3});
  LbExperimentConfig config;
  config.run.steps = 40;
  config.run.territories = 2;
  config.run.partition = "grid:2x1x1";
  config.run.threads = 1;
  config.run.progress_seconds = 0;
  config.run.runtime.balance.period = 10;
  config.policies = {"none", "churn"};
  config.baseline = false;
  const LbExperimentResult r = run_lb_experiment(scene, config);
  ASSERT_EQ(r.runs.size(), 2u);
  EXPECT_TRUE(r.hashes_equal);
  EXPECT_EQ(r.runs[0].best.state_hash, r.runs[1].best.state_hash);
  // Every policy against one territory, run apart from the experiment.
  RunConfig one = config.run;
  one.territories = 1;
  one.runtime.balance = {};
  const std::uint64_t one_hash = run_scene(scene, one).state_hash;
  EXPECT_EQ(hash_hex(r.one_territory_hash), hash_hex(one_hash));
  EXPECT_TRUE(r.equals_one_territory);
  for (const LbPolicyRun& run : r.runs) {
    EXPECT_TRUE(run.equals_one_territory) << run.policy;
    EXPECT_EQ(hash_hex(run.best.state_hash), hash_hex(one_hash)) << run.policy;
  }
  EXPECT_TRUE(r.runs[0].best.balance_log.empty());
  ASSERT_FALSE(r.runs[1].best.balance_log.empty());
  EXPECT_GT(balance_totals(r.runs[1].best.balance_log).cells_moved, 0);

  std::ostringstream steps, balance, maps;
  write_steps_csv(steps, r);
  write_balance_csv(balance, r);
  EXPECT_EQ(lines(steps.str()), 1u + 2u * 40u * 2u);  // header, policies x steps x worlds
  // What each world gave at churn's balance steps adds up to balance.csv's cells_moved.
  {
    std::istringstream in(steps.str());
    std::string row;
    std::getline(in, row);
    EXPECT_EQ(row, "policy,step,world,busy_ms,wait_ms,bodies,cells,lead,islands,cells_out,cells_in,bodies_out,bodies_in");
    long long out_sum = 0, in_sum = 0, bodies_out = 0;
    while (std::getline(in, row)) {
      std::vector<std::string> f;
      std::stringstream fields(row);
      for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
      ASSERT_EQ(f.size(), 13u) << row;
      out_sum += std::stoll(f[9]), in_sum += std::stoll(f[10]), bodies_out += std::stoll(f[11]);
      if (f[0] == "none") {
        for (std::size_t i = 9; i < 13; ++i) EXPECT_EQ(f[i], "0") << row;
      }
    }
    const BalanceTotals t = balance_totals(r.runs[1].best.balance_log);
    EXPECT_EQ(out_sum, t.cells_moved);
    EXPECT_EQ(in_sum, t.cells_moved);
    EXPECT_EQ(bodies_out, t.bodies_moved);
  }
  EXPECT_EQ(lines(balance.str()), 1u + r.runs[1].best.balance_log.size());
  write_maps_csv(maps, r, {0, 40});
  EXPECT_EQ(lines(maps.str()), 1u + 2u * 2u * static_cast<std::size_t>(r.first_map.box().count()));

  // The last map of churn is the first with every move applied, and differs from it.
  const TerritoryMap last = map_at(r.first_map, r.runs[1].best.balance_log, 40);
  EXPECT_FALSE(last == r.first_map);
  for (const BalanceRecord& rec : r.runs[1].best.balance_log)
    for (const CellMove& m : rec.moves) EXPECT_NE(m.from, m.to);

  const nlohmann::json j = lb_summary_json({"falling-cubes", {.n = 150, .seed = 3}, &scene, config.run}, config, r);
  ASSERT_EQ(j["policies"].size(), 2u);
  EXPECT_EQ(j["policies"][1]["policy"], "churn");
  EXPECT_GT(j["policies"][1]["cells_moved"].get<long long>(), 0);
  EXPECT_TRUE(j["hashes_equal"].get<bool>());
  EXPECT_EQ(j["policies"][0]["state_hash"], j["policies"][1]["state_hash"]);
  EXPECT_EQ(j["one_territory_state_hash"], hash_hex(one_hash));
  EXPECT_TRUE(j["state_hash_equals_one_territory"].get<bool>());
  for (const nlohmann::json& p : j["policies"]) EXPECT_TRUE(p["state_hash_equals_one_territory"].get<bool>()) << p;
}

TEST(LbExperiment, RefusesUnknownPoliciesAndOneTerritoryBeforeRunning) {
  const Scene scene = make_scene("falling-cubes", {.n = 20, .seed = 1});
  LbExperimentConfig config;
  config.run.steps = 5;
  config.run.territories = 2;
  config.run.partition = "grid:2x1x1";
  config.policies = {"none", "sideways"};
  EXPECT_THROW(run_lb_experiment(scene, config), BalanceError);
  config.policies = {"none", "none"};
  EXPECT_THROW(run_lb_experiment(scene, config), std::invalid_argument);
  config.policies = {"none"};
  config.run.territories = 1;
  EXPECT_THROW(run_lb_experiment(scene, config), std::invalid_argument);
}

}  // namespace
}  // namespace soda
