// `soda run --lb ...` (docs/loadbalance.md, docs/cli.md): load balancing
// changes who simulates which cells, never the result; the summary and the
// JSON carry the balance totals; bad values exit 2 naming the option.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/cli_test_util.h"

namespace {

using namespace soda_cli_test;

TEST_F(CliTest, ChurnMovesCellsAndBodiesAndKeepsTheOneTerritoryHash) {
  const Outcome one = run_cli("run --scene falling-cubes --n 150 --steps 60 --log-level warn");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string out = (dir_ / "lb.json").string();
  const Outcome o = run_cli("run --scene falling-cubes --n 150 --steps 60 --territories 4 --lb churn --lb-period 6 "
                            "--lb-seed 3 --lb-max-cells 2 --validate --log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_EQ(hash_of(o), hash_of(one)) << o.output;
  EXPECT_NE(o.output.find("load balancing: 9 balance steps"), std::string::npos) << o.output;
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& b = j["balance"];
  EXPECT_EQ(b["policy"], "churn");
  EXPECT_EQ(b["period"], 6);
  EXPECT_EQ(b["seed"], 3);
  EXPECT_EQ(b["balance_steps"], 9);
  EXPECT_EQ(b["cells_moved"], 18);  // 2 cells per balance step: churn draws from cells holding bodies
  EXPECT_GT(b["bodies_moved"].get<int>(), 0);
  EXPECT_GT(b["cpu_seconds"].get<double>(), 0.0);
  EXPECT_EQ(b["steps"].size(), 9u);
  EXPECT_EQ(j["bodies_at_end"], j["bodies_at_start"]);
}

TEST_F(CliTest, BadBalanceOptionsExitTwoNamingThem) {
  const std::string run = "run --scene falling-cubes --n 30 --steps 5 --territories 2 ";
  struct Bad {
    const char* args;
    const char* needle;
  };
  for (const Bad& bad : {Bad{"--lb bogus", "unknown balance policy 'bogus'"},
                         Bad{"--lb churn --lb-period 0", "--lb-period"},
                         Bad{"--lb churn --lb-max-cells 0", "--lb-max-cells"},
                         Bad{"--lb churn --lb-seed -2", "--lb-seed"},
                         Bad{"--lb churn --lb-smoothing 0", "smoothing"},
                         Bad{"--lb churn --lb-overload 0.9", "overload"},
                         Bad{"--lb churn --lb-underload 1.5", "underload"}}) {
    const Outcome o = run_cli(run + bad.args);
    EXPECT_EQ(o.exit_code, 2) << bad.args << "\n" << o.output;
    EXPECT_NE(o.output.find(bad.needle), std::string::npos) << bad.args << "\n" << o.output;
  }
}

// Inputs under a balance policy go to the PartitionedWorld
// (PartitionedOptions::inputs): the hash of the Simulation's replay.
TEST_F(CliTest, InputsWithABalancePolicyGiveTheSimulationHash) {
  const std::string inputs = write("inputs.json", R"({"format": "soda-inputs", "version": 1, "inputs": [
    {"type": "apply_impulse", "step": 3, "id": 3, "impulse": [1, 0, 0]}]})");
  const std::string run = "run --scene falling-cubes --n 30 --steps 20 --inputs " + inputs;
  const Outcome api = run_cli(run + " --territories 2");
  ASSERT_EQ(api.exit_code, 0) << api.output;
  const Outcome lb = run_cli(run + " --territories 2 --lb churn --lb-period 4 --validate");
  ASSERT_EQ(lb.exit_code, 0) << lb.output;
  EXPECT_EQ(hash_of(lb), hash_of(api)) << lb.output;
  EXPECT_NE(hash_of(lb), hash_of(run_cli("run --scene falling-cubes --n 30 --steps 20"))) << "the input does something";
}

// rain's later waves are inputs of the scene (scene_inputs): `soda run`
// applies them itself, balanced or not, validated, with one hash; an input
// file on top of them is refused.
TEST_F(CliTest, RainAppliesItsOwnInputsUnderEveryPolicy) {
  const std::string rain = "run --scene rain --n 64 --steps 120 ";
  const Outcome one = run_cli(rain);
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_NE(one.output.find("33 bodies"), std::string::npos) << "two waves added by inputs\n" << one.output;
  for (const char* args : {"--territories 4 --lb churn --validate", "--territories 4 --lb diffusive --anticipation 8",
                           "--territories 2 --lb churn --sync-test 1 --validate", "--territories 4 --validate"}) {
    const Outcome o = run_cli(rain + args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    EXPECT_EQ(hash_of(o), hash_of(one)) << args << "\n" << o.output;
  }
  const std::string inputs = write("inputs.json", R"({"format": "soda-inputs", "version": 1, "inputs": []})");
  const Outcome both = run_cli(rain + "--inputs " + inputs);
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_NE(both.output.find("has 60 inputs of its own"), std::string::npos) << both.output;
}

// The triangles of level geometry in the partition and the balance
// (docs/loadbalance.md, "Triangles"): soda partition shows and weighs them,
// a bad weight exits 2, and a balanced terrain run keeps the one-territory
// hash with the triangle cost on and off.
TEST_F(CliTest, TriangleCostShowsInThePartitionAndKeepsTheHash) {
  const Outcome p = run_cli("partition --scene terrain --n 40 --territories 4 --json -");
  ASSERT_EQ(p.exit_code, 0) << p.output;
  EXPECT_NE(p.output.find("body triangles"), std::string::npos) << p.output;
  EXPECT_NE(p.output.find("\"weighted_imbalance\""), std::string::npos) << p.output;
  EXPECT_EQ(run_cli("partition --scene terrain --n 40 --territories 4 --triangle-weight 0").exit_code, 0);
  const Outcome bad = run_cli("partition --scene terrain --n 40 --territories 4 --triangle-weight -1");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--triangle-weight"), std::string::npos) << bad.output;
  const std::string one = hash_of(run_cli("run --scene terrain --n 40 --steps 60"));
  ASSERT_EQ(one.size(), 16u);
  for (const char* extra : {"", " --no-triangle-cost"}) {
    const Outcome o = run_cli(std::string("run --scene terrain --n 40 --steps 60 --territories 4 --lb diffusive "
                                          "--lb-period 10 --lb-overload 1.05 --lb-underload 0.95") + extra);
    EXPECT_EQ(o.exit_code, 0) << o.output;
    EXPECT_EQ(hash_of(o), one) << extra << o.output;
  }
}

}  // namespace
