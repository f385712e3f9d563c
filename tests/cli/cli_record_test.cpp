// `soda run --record FILE` and `soda replay-info FILE` end to end.
#include <utility>
#include <vector>

#include "cli_test_util.h"

namespace soda_cli_test {
namespace {

TEST_F(CliTest, RecordKeepsTheHashAndReplayInfoReadsIt) {
  const std::string file = (dir_ / "r.replay").string();
  const std::string args = "run --scene falling-cubes --n 100 --steps 60 --territories 2 --threads 1";
  const Outcome plain = run_cli(args);
  const Outcome recorded = run_cli(args + " --record " + file);
  ASSERT_EQ(recorded.exit_code, 0) << recorded.output;
  EXPECT_EQ(hash_of(recorded), hash_of(plain));
  EXPECT_NE(recorded.output.find("recorded 61 frames"), std::string::npos) << recorded.output;
  const Outcome info = run_cli("replay-info " + file);
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("2 territories, 101 bodies (100 dynamic)"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("frames: 61 (steps 0 .. 60)"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("state_hash " + hash_of(plain)), std::string::npos) << info.output;
}

// With inputs: the hash of the run unrecorded, and a file whose frames hold
// the body the input adds (replay-info names it) and the run's hash. The
// registry's rain (inputs of its own: waves of bodies) records too.
TEST_F(CliTest, RecordWithInputsKeepsTheHashAndHoldsTheAddedBodies) {
  const std::string inputs = write("inputs.json", R"({"format": "soda-inputs", "version": 1, "inputs": [
    {"type": "add_body", "step": 10, "body": {"id": 500, "type": "dynamic", "mass": 1,
      "shape": {"type": "box", "half_extents": [1.0, 0.1, 0.3]}, "position": [0, 9, 0]}},
    {"type": "remove_body", "step": 20, "id": 3}]})");
  const std::string file = (dir_ / "inputs.replay").string();
  for (int k : {1, 4}) {
    const std::string args = "run --scene falling-cubes --n 100 --steps 40 --territories " + std::to_string(k) +
                             " --inputs " + inputs;
    const Outcome plain = run_cli(args);
    const Outcome recorded = run_cli(args + " --record " + file);
    ASSERT_EQ(recorded.exit_code, 0) << recorded.output;
    EXPECT_EQ(hash_of(recorded), hash_of(plain)) << "K = " << k;
    const Outcome info = run_cli("replay-info " + file);
    ASSERT_EQ(info.exit_code, 0) << info.output;
    EXPECT_NE(info.output.find("format version 3"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("bodies added during the run: 1 (ids 500 .. 500)"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("last frame: step 40, 100 bodies"), std::string::npos) << info.output;  // +500, -3
    EXPECT_NE(info.output.find("state_hash " + hash_of(plain)), std::string::npos) << info.output;
  }
  const std::string rain = "run --scene rain --n 200 --steps 150 --territories 2";
  const Outcome plain = run_cli(rain);
  const Outcome recorded = run_cli(rain + " --record " + file);
  ASSERT_EQ(recorded.exit_code, 0) << recorded.output;
  EXPECT_EQ(hash_of(recorded), hash_of(plain));
  EXPECT_NE(run_cli("replay-info " + file).output.find("bodies added during the run"), std::string::npos);
}

TEST_F(CliTest, ReplayInfoOfANonReplayIsBadInput) {
  const std::string path = write("not.replay", "hello, this is not a replay file at all");
  const Outcome o = run_cli("replay-info " + path);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find(path + ": not a replay file"), std::string::npos) << o.output;
}

TEST_F(CliTest, RecordRefusesLoadBalancing) {
  const Outcome o = run_cli("run --scene falling-cubes --n 50 --steps 5 --territories 2 --lb diffusive --record " +
                            (dir_ / "r.replay").string());
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("--record"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("--lb"), std::string::npos) << o.output;
}

// --record and --serve refuse, from the one list (simulation_unsupported),
// every option a Simulation cannot run, each naming the option: exit 2,
// before any port is opened or file written.
TEST_F(CliTest, RecordAndServeRefuseWhatASimulationCannotRun) {
  const std::string base = "run --scene falling-cubes --n 50 --steps 5 --territories 2 ";
  for (const auto& [option, named] : std::vector<std::pair<std::string, std::string>>{
           {"--world stock", "--world stock"},
           {"--sync-test 1", "--sync-test"},
           {"--lb churn", "--lb"},
           {"--watchdog heal", "--watchdog heal"}}) {
    for (const std::string& mode : {"--record " + (dir_ / "r.replay").string(), std::string("--serve 0")}) {
      const Outcome o = run_cli(base + option + " " + mode);
      EXPECT_EQ(o.exit_code, 2) << option << " " << mode << ": " << o.output;
      EXPECT_NE(o.output.find(named), std::string::npos) << option << " " << mode << ": " << o.output;
      EXPECT_NE(o.output.find(mode.substr(0, mode.find(' '))), std::string::npos) << o.output;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir_ / "r.replay"));
}

}  // namespace
}  // namespace soda_cli_test
