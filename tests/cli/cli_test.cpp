// The CLI end to end: bad input gives a clear message and exit code 2 (never
// a crash), bench writes the documented JSON fields.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli/cli_test_util.h"

namespace {

using namespace soda_cli_test;

TEST_F(CliTest, NanNumber) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 1},
      "position": [0, NaN, 0]})"), "body #1 (id 3): field 'position[1]'");
}
TEST_F(CliTest, InfiniteNumber) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1e400, "shape": {"type": "sphere", "radius": 1},
      "position": [0, 2, 0]})"), "body #1 (id 3): field 'mass'");
}
TEST_F(CliTest, NonPositiveMass) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 0, "shape": {"type": "sphere", "radius": 1},
      "position": [0, 2, 0]})"), "body #1 (id 3): field 'mass'");
}
TEST_F(CliTest, NegativeExtent) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [1, -1, 1]},
      "position": [0, 2, 0]})"), "body #1 (id 3): field 'shape.half_extents'");
}
TEST_F(CliTest, UnknownShape) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "cone"},
      "position": [0, 2, 0]})"), "unknown shape 'cone'");
}
TEST_F(CliTest, DuplicateId) {
  expect_bad_input(bad_scene(R"({"id": 0, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 1},
      "position": [0, 2, 0]})"), "body #1 (id 0): field 'id': duplicate id");
}
TEST_F(CliTest, MissingField) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "position": [0, 2, 0]})"),
                   "body #1 (id 3): field 'shape': missing");
}
TEST_F(CliTest, MistypedField) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": "big"},
      "position": [0, 2, 0]})"), "body #1 (id 3): field 'shape.radius': must be a number");
}
TEST_F(CliTest, BodyBulletWouldDisable) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 1e6},
      "position": [0, 2, 0]})"), "1e12");
}
TEST_F(CliTest, UnreadableFile) {
  const std::string path = (dir_ / "missing.json").string();
  expect_bad_input(path, "cannot open");
}

TEST_F(CliTest, UnknownSceneAndBadOptionsExitTwo) {
  Outcome o = run_cli("run --scene no-such-scene");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("falling-cubes"), std::string::npos) << o.output;
  o = run_cli("run --steps many");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  o = run_cli("run --scene falling-cubes --n 10 --dt -1");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("'dt'"), std::string::npos) << o.output;
  o = run_cli("run --world gpu");
  EXPECT_EQ(o.exit_code, 2) << o.output;
}

TEST_F(CliTest, BenchWritesDocumentedJson) {
  const std::string out = (dir_ / "out.json").string();
  const Outcome o = run_cli("bench falling-cubes --n 100 --steps 20 --repeat 2 --log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* field : {"scene", "params", "seed", "territories", "threads", "precision", "dt", "iterations",
                            "steps", "bodies", "state_hash", "wall_seconds", "step_ms", "baseline_wall_seconds",
                            "ratio_vs_baseline", "ratio_vs_baseline_note", "sleeping_bodies",
                            "baseline_sleeping_bodies", "ratio_vs_baseline_awake", "ratio_vs_baseline_awake_note",
                            "awake", "exit_code"})
    EXPECT_TRUE(j.contains(field)) << field << " missing in " << j.dump();
  EXPECT_EQ(j["awake"]["sleeping_bodies"], 0);
  EXPECT_EQ(j["awake"]["baseline_sleeping_bodies"], 0);
  EXPECT_EQ(j["exit_code"], 0);
  // Every speed ratio is baseline time / our time (> 1: faster than stock).
  EXPECT_NEAR(j["ratio_vs_baseline_awake"].get<double>(),
              j["awake"]["baseline_wall_seconds"].get<double>() / j["awake"]["wall_seconds"].get<double>(), 1e-9);
  EXPECT_NE(o.output.find("sleeping off"), std::string::npos) << o.output;  // the table
  EXPECT_EQ(j["bodies"], 101);
  EXPECT_EQ(j["steps"], 20);
  EXPECT_EQ(j["state_hash"].get<std::string>().size(), 16u);
  EXPECT_GT(j["baseline_wall_seconds"].get<double>(), 0.0);
  EXPECT_NEAR(j["ratio_vs_baseline"].get<double>(),
              j["baseline_wall_seconds"].get<double>() / j["wall_seconds"].get<double>(), 1e-9);
  EXPECT_EQ(j["wall_seconds_all"].size(), 2u);
}

// `soda bench broadphase`: every broadphase reports the same exact pairs at
// every step (and, this small, the pairs of every two bodies tested), some
// pairs at the end, and a positive ratio dbvt / it.
TEST_F(CliTest, BenchBroadphaseReportsTheSameExactPairs) {
  const std::string out = (dir_ / "broadphase.json").string();
  const Outcome o = run_cli("bench broadphase --scene falling-cubes --n 200 --steps 30 --repeat 1 --out " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  EXPECT_EQ(j["exact_pairs_equal"], true) << j.dump();
  EXPECT_EQ(j["exact_pairs_equal_to_brute_force"], true) << j.dump();
  EXPECT_EQ(j["steps"], 30);
  ASSERT_EQ(j["broadphases"].size(), 4u) << j.dump();
  for (const nlohmann::json& b : j["broadphases"]) {
    const std::string name = b["broadphase"].get<std::string>();
    EXPECT_EQ(b["exact_pairs_equal_to_dbvt"], true) << name;
    EXPECT_GT(b["raw_pairs_end"].get<std::size_t>(), 0u) << name;
    EXPECT_GT(b["exact_pairs_end"].get<std::size_t>(), 0u) << name;
    EXPECT_GE(b["raw_pairs_end"].get<std::size_t>(), b["exact_pairs_end"].get<std::size_t>()) << name;
    EXPECT_GT(b["ratio_vs_dbvt"].get<double>(), 0.0) << name;
    EXPECT_EQ(b["seconds"].size(), 1u) << name;
  }
  EXPECT_EQ(j["broadphases"][0]["broadphase"], "dbvt");  // the baseline
  EXPECT_DOUBLE_EQ(j["broadphases"][0]["ratio_vs_dbvt"].get<double>(), 1.0);
}

// One meaning of every speed ratio, named in the help of soda, soda bench,
// the benchmarks under it and soda lb.
TEST_F(CliTest, HelpNamesTheMeaningOfTheRatios) {
  for (const char* args : {"--help", "bench --help", "bench speculation --help", "bench sleepers --help",
                           "lb --help"}) {
    const Outcome o = run_cli(args);
    EXPECT_EQ(o.exit_code, 0) << args << ": " << o.output;
    EXPECT_NE(o.output.find("baseline time / our time, > 1 is faster"), std::string::npos) << args << ": "
                                                                                              << o.output;
  }
}

TEST_F(CliTest, ShuffleSeedDoesNotChangeTheCanonicalHash) {
  std::string first;
  for (const char* seed : {"0", "5", "9"}) {
    const Outcome o = run_cli(std::string("run --scene cube-pile --n 120 --steps 200 --shuffle-seed ") + seed);
    ASSERT_EQ(o.exit_code, 0) << o.output;
    const std::string h = hash_of(o);
    ASSERT_EQ(h.size(), 16u) << o.output;
    std::printf("shuffle seed %s: state_hash %s\n", seed, h.c_str());
    if (first.empty()) first = h;
    EXPECT_EQ(h, first) << "seed " << seed;
  }
}

// --shuffle-seed with several territories: every world inserts its bodies
// shuffled; the hash stays the one-territory, scene-order hash.
TEST_F(CliTest, ShuffleSeedWithTerritoriesKeepsTheHash) {
  const Outcome one = run_cli("run --scene cube-pile --n 120 --steps 120");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  for (const char* seed : {"5", "9"}) {
    const Outcome o =
        run_cli(std::string("run --scene cube-pile --n 120 --steps 120 --territories 2 --shuffle-seed ") + seed);
    ASSERT_EQ(o.exit_code, 0) << o.output;
    EXPECT_EQ(hash_of(o), hash_of(one)) << "seed " << seed << "\n" << o.output;
  }
}

// The bench of K territories checks the hash in both sleeping settings and
// exits 0 when they agree (the exit 1 on a mismatch: BenchExitCode tests).
TEST_F(CliTest, BenchWithTerritoriesChecksTheHashSleepingOnAndOff) {
  const std::string out = (dir_ / "out.json").string();
  const Outcome o = run_cli("bench cube-pile --n 80 --steps 60 --repeat 1 --territories 2 --shuffle-seed 4 "
                            "--log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["state_hash_equals_one_territory"], true);
  EXPECT_EQ(j["state_hash_equals_one_territory_awake"], true);
  EXPECT_EQ(j["awake"]["one_territory_sleeping_bodies"], 0);
  EXPECT_NE(o.output.find("state hash, 2 territories vs 1: identical"), std::string::npos) << o.output;
}

TEST_F(CliTest, ExportedSceneRunsToTheSameHash) {
  const std::string file = (dir_ / "cubes.json").string();
  Outcome o = run_cli("export-scene --scene falling-cubes --n 60 --seed 4 -o " + file);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const std::string a_json = (dir_ / "a.json").string(), b_json = (dir_ / "b.json").string();
  o = run_cli("run --scene falling-cubes --n 60 --seed 4 --steps 50 --json " + a_json);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  o = run_cli("run --scene " + file + " --steps 50 --json " + b_json);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const auto a = nlohmann::json::parse(std::ifstream(a_json));
  const auto b = nlohmann::json::parse(std::ifstream(b_json));
  EXPECT_EQ(a["state_hash"], b["state_hash"]);
}

}  // namespace

namespace {

class CliWatchdog : public CliTest {
 protected:
  // A body thrown at 20 km/s: valid input, absurd physics.
  std::string absurd_scene() {
    return write("absurd.json", R"({"format": "soda-scene", "version": 1, "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
      {"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
       "position": [0, 2, 0], "linear_velocity": [20000, 0, 0]}]})");
  }
};

TEST_F(CliWatchdog, StopNamesTheStepAndTheBody) {
  const std::string scene = absurd_scene();
  for (const char* territories : {"1", "2"}) {
    const Outcome o = run_cli("run --scene " + scene + " --steps 3 --territories " + territories);
    EXPECT_EQ(o.exit_code, 1) << o.output;
    EXPECT_NE(o.output.find("watchdog: step 1"), std::string::npos) << o.output;
    EXPECT_NE(o.output.find("body 7: speed"), std::string::npos) << o.output;
  }
  const Outcome off = run_cli("run --scene " + scene + " --steps 3 --watchdog off");
  EXPECT_EQ(off.exit_code, 0) << off.output;
}

TEST_F(CliWatchdog, HealThatCannotHelpGivesUpClearly) {
  const Outcome o = run_cli("run --scene " + absurd_scene() + " --steps 3 --watchdog heal");
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_NE(o.output.find("self-heal gave up"), std::string::npos) << o.output;
}

// A real blow-up (the README's example): a 1000 kg box on a 1 kg box
// stepped at 0.33 s with 5 iterations sinks 1.05 m into it in step 4. Stop
// names step 5, whose contacts find it; heal re-simulates step 4 in
// substeps, and step 13, where the falling stack sinks again, and the run
// ends normally, every other step within the watchdog's limits.
TEST_F(CliWatchdog, HealSavesARealBlowUp) {
  const std::string run = "run --scene mass-ratio --n 1000 --dt 0.33 --iterations 5 --steps 60 --log-level warn ";
  const Outcome stop = run_cli(run);
  EXPECT_EQ(stop.exit_code, 1) << stop.output;
  EXPECT_NE(stop.output.find("watchdog: step 5"), std::string::npos) << stop.output;
  EXPECT_NE(stop.output.find("penetrates"), std::string::npos) << stop.output;
  const std::string out = (dir_ / "healed.json").string();
  const Outcome heal = run_cli(run + "--watchdog heal --json " + out);
  ASSERT_EQ(heal.exit_code, 0) << heal.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  EXPECT_EQ(j["healed_steps"], nlohmann::json::array({4, 13})) << j.dump();
  EXPECT_EQ(j["steps"], 60);
}

TEST_F(CliWatchdog, BadResponseIsBadInput) {
  const Outcome o = run_cli("run --scene cube-pile --n 20 --steps 1 --watchdog fix");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("off, stop or heal"), std::string::npos) << o.output;
}

}  // namespace

namespace {

// `--anticipation` and `--rollback` (speculation, docs/rollback.md): bad
// values are bad input; any anticipation keeps the one-territory hash.
class CliSpeculation : public CliTest {};

TEST_F(CliSpeculation, NegativeAnticipationIsBadInput) {
  const Outcome o = run_cli("run --scene falling-cubes --n 20 --steps 1 --territories 2 --anticipation -1");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("--anticipation"), std::string::npos) << o.output;
}

TEST_F(CliSpeculation, AnticipationWithHealIsRefused) {
  const Outcome o = run_cli("run --scene falling-cubes --n 20 --steps 1 --anticipation 8 --watchdog heal");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("--anticipation"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("--watchdog heal"), std::string::npos) << o.output;
}

TEST_F(CliSpeculation, UnknownRollbackIsBadInput) {
  const Outcome o = run_cli("run --scene falling-cubes --n 20 --steps 1 --territories 2 --anticipation 4 "
                            "--rollback sideways");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("propagate"), std::string::npos) << o.output;
}

TEST_F(CliSpeculation, AnticipationKeepsTheOneTerritoryHash) {
  const std::string scene = "run --scene falling-cubes --n 300 --seed 3 --steps 90 --log-level warn ";
  const Outcome one = run_cli(scene + "--territories 1");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string expected = hash_of(one);
  ASSERT_EQ(expected.size(), 16u) << one.output;
  std::printf("territories 1: state_hash %s\n", expected.c_str());
  // Each run really speculated: its JSON counts the bets it made.
  for (const char* args : {"--territories 4 --anticipation 8",
                           "--territories 4 --anticipation 8 --rollback recompute --threads 1"}) {
    const std::string out = (dir_ / "anticipation.json").string();
    const Outcome o = run_cli(scene + args + " --json " + out);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
    const std::uint64_t bets = j["speculation"]["bets"].get<std::uint64_t>();
    std::printf("%s: state_hash %s, %llu bets\n", args, hash_of(o).c_str(), static_cast<unsigned long long>(bets));
    EXPECT_EQ(hash_of(o), expected) << args << "\n" << o.output;
    EXPECT_EQ(j["anticipation"], 8) << args;
    EXPECT_GT(bets, 0u) << args << ": no bet made, so nothing speculative was compared";
  }
}

// The speculation benchmark's scene: on two territories (k-means) nothing
// crosses or comes near the cut, and the hash is the one-territory hash.
TEST_F(CliSpeculation, AlternatingLoadNeverTouchesTheCut) {
  const std::string scene = "run --scene alternating-load --n 300 --steps 320 --log-level warn ";
  const Outcome one = run_cli(scene + "--territories 1");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string out = (dir_ / "alt.json").string();
  const Outcome two = run_cli(scene + "--territories 2 --anticipation 16 --json " + out);
  ASSERT_EQ(two.exit_code, 0) << two.output;
  std::printf("alternating-load: territories 1 %s, territories 2 %s\n", hash_of(one).c_str(), hash_of(two).c_str());
  EXPECT_EQ(hash_of(one), hash_of(two));
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  ASSERT_EQ(j["worlds"].size(), 2u);
  for (const nlohmann::json& w : j["worlds"]) {
    EXPECT_EQ(w["owned_bodies"], 200) << w.dump();  // 150 cubes and 50 wake boxes a side
    EXPECT_EQ(w["border_bodies"], 0) << w.dump();
    EXPECT_EQ(w["ghosts_sent"], 0) << w.dump();
    EXPECT_EQ(w["migrations_out"], 0) << w.dump();
  }
}

TEST_F(CliSpeculation, RunJsonHasSpeculationFields) {
  const std::string out = (dir_ / "spec.json").string();
  const Outcome o = run_cli("run --scene falling-cubes --n 100 --steps 20 --territories 2 --anticipation 4 "
                            "--rollback recompute --log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  EXPECT_EQ(j["anticipation"], 4);
  EXPECT_EQ(j["rollback"], "recompute");
  for (const char* field : {"bets", "bets_lost", "rollbacks", "steps_rolled_back", "bodies_resolved",
                            "bodies_resolved_per_rollback", "rollback_cpu_seconds", "lead_max", "lead_mean",
                            "kept_states_max"})
    EXPECT_TRUE(j["speculation"].contains(field)) << field << " missing in " << j["speculation"].dump();
  ASSERT_EQ(j["worlds"].size(), 2u);
  for (const char* field : {"bets", "bets_lost", "rollbacks", "steps_rolled_back", "bodies_resolved",
                            "rollback_cpu_seconds", "lead_max", "lead_mean", "kept_states_max"})
    EXPECT_TRUE(j["worlds"][0].contains(field)) << field << " missing in " << j["worlds"][0].dump();
  EXPECT_FALSE(j["worlds"][0].contains("lead"));  // the per-step series is not dumped
  // Per-stage costs (stage.h): every stage by name, each with its fields.
  const nlohmann::json& stages = j["worlds"][0]["stages"];
  for (const char* stage : {"predict", "exchange_ghosts", "collide", "build_islands", "glue", "merge", "solve",
                            "integrate", "migrate", "publish", "receive", "checkpoint", "rollback", "idle"})
    for (const char* field : {"cpu_seconds", "wait_seconds", "items", "messages", "bytes"})
      EXPECT_TRUE(stages.contains(stage) && stages[stage].contains(field)) << stage << "." << field << " missing";
  EXPECT_TRUE(j["worlds"][0].contains("thread_cpu_seconds"));
}

// The process's CPU (docs/cli.md): every thread, so at least the stepping
// thread's, which is all cpu_seconds counts in one territory.
TEST_F(CliTest, RunJsonHasTheProcessCpuBesideTheSteppingThreads) {
  const std::string out = (dir_ / "cpu.json").string();
  const Outcome o = run_cli("run --scene cube-pile --n 200 --steps 60 --solver-threads 2 --log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  ASSERT_TRUE(j.contains("process_cpu_seconds")) << j.dump();
  EXPECT_GT(j["process_cpu_seconds"].get<double>(), 0.0);
  EXPECT_GE(j["process_cpu_seconds"].get<double>(), j["cpu_seconds"].get<double>());
}

// Messages by destination and kind (docs/cli.md, "traffic"): with
// --serialise every flow has its encoded bytes and they add up to the run's
// message_bytes; each world sends the other one Ghosts per step.
TEST_F(CliTest, RunJsonHasTrafficByDestinationAndKind) {
  const std::string out = (dir_ / "traffic.json").string();
  const Outcome o = run_cli("run --scene falling-cubes --n 100 --steps 20 --territories 2 --serialise "
                            "--log-level warn --json " + out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  ASSERT_EQ(j["worlds"].size(), 2u);
  std::uint64_t bytes = 0, messages = 0;
  for (const nlohmann::json& w : j["worlds"]) {
    const nlohmann::json& t = w["traffic"];
    EXPECT_EQ(t["internal_steps"], 20);
    EXPECT_EQ(t["rounds"]["ghosts"], 20);
    bool ghosts = false;
    for (const nlohmann::json& f : t["flows"]) {
      EXPECT_EQ(f["to"], 1 - w["world"].get<int>());
      EXPECT_GT(f["bytes"].get<std::uint64_t>(), 0u);
      if (f["kind"] == "ghosts") ghosts = f["messages"] == 20;
      bytes += f["bytes"].get<std::uint64_t>();
      messages += f["messages"].get<std::uint64_t>();
    }
    EXPECT_TRUE(ghosts) << t.dump();
    EXPECT_TRUE(t.contains("island_depth_sum") && t.contains("island_depth_max"));
  }
  EXPECT_EQ(bytes, j["message_bytes"].get<std::uint64_t>());
  EXPECT_EQ(messages, j["messages"].get<std::uint64_t>());
}

}  // namespace

namespace {

// `soda bench speculation` (docs/speculation-bench.md): its JSON has every
// documented figure and the hashes of all runs but the stock one agree.
class CliSpeculationBench : public CliTest {};

TEST_F(CliSpeculationBench, WritesDocumentedJson) {
  const std::string out = (dir_ / "spec.json").string();
  const Outcome o = run_cli("bench speculation --n 120 --steps 40 --repeat 1 --anticipation 8 --log-level warn --out " +
                            out);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("\"benchmark\": \"speculation\""), std::string::npos) << o.output;  // JSON on stdout
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(out));
  for (const char* field : {"scene", "params", "seed", "precision", "dt", "iterations", "steps", "bodies",
                            "territories", "partition", "anticipation", "baseline_wall_seconds", "runs",
                            "speedup_propagate_vs_lockstep", "speedup_recompute_vs_lockstep", "bound",
                            "modelled_speedup", "lockstep_load_by_window", "bodies_resolved_propagate_over_recompute",
                            "all_repeats", "one_territory_state_hash", "state_hashes_equal"})
    EXPECT_TRUE(j.contains(field)) << field << " missing";
  for (const char* field : {"bets_lost", "rollbacks", "bodies_resolved", "bodies_replayed"})
    EXPECT_TRUE(j["all_repeats"]["propagate"].contains(field)) << field << " missing";
  EXPECT_EQ(j["scene"], "alternating-load");
  EXPECT_TRUE(j["state_hashes_equal"].get<bool>());
  ASSERT_EQ(j["runs"].size(), 5u);
  const char* names[] = {"stock", "one-territory", "lockstep", "propagate", "recompute"};
  for (std::size_t i = 0; i < 5; ++i) {
    const nlohmann::json& run = j["runs"][i];
    EXPECT_EQ(run["name"], names[i]);
    EXPECT_GT(run["wall_seconds"].get<double>(), 0.0);
    EXPECT_NEAR(run["ratio_vs_baseline"].get<double>(),
                j["baseline_wall_seconds"].get<double>() / run["wall_seconds"].get<double>(), 1e-9);
    if (i >= 1) {
      EXPECT_EQ(run["state_hash"], j["one_territory_state_hash"]) << names[i];
    }
    if (i >= 2) {
      EXPECT_EQ(run["worlds"].size(), 2u);
      EXPECT_TRUE(run["speculation"].contains("bodies_resolved_per_rollback"));
      EXPECT_TRUE(run["speculation"].contains("bodies_replayed"));
      EXPECT_TRUE(run["worlds"][0].contains("lead_max"));
    }
  }
  EXPECT_EQ(j["runs"][3]["anticipation"], 8);
  EXPECT_EQ(j["runs"][4]["rollback"], "recompute");
  EXPECT_GE(j["bound"].get<double>(), 1.0);
}

TEST_F(CliSpeculationBench, OneTerritoryIsBadInput) {
  const Outcome o = run_cli("bench speculation --n 60 --steps 5 --repeat 1 --territories 1");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("--territories"), std::string::npos) << o.output;
}

// Out of memory (docs/memory.md): exit code 3 and a message, never a crash.
// Before: SIGSEGV in Bullet's allocator (NULL, then memset) or "failed:
// std::bad_alloc" with exit code 1.
TEST(CliMemory, ARunThatCannotFitIsRefusedBeforeBuilding) {
  // 300,000 cubes need ~0.6 GB of worlds; the limit leaves less.
  const Outcome o = run_cli("run --scene falling-cubes --n 300000 --steps 1", "ulimit -v 600000; ");
  EXPECT_EQ(o.exit_code, 3) << o.output;
  EXPECT_NE(o.output.find("out of memory"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("RLIMIT_AS"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("300001 bodies"), std::string::npos) << o.output;
}

TEST(CliMemory, AnAllocationThatFailsIsACleanError) {
  // The scene itself (3,000,000 cubes) does not fit: std::bad_alloc while generating.
  const Outcome o = run_cli("run --scene falling-cubes --n 3000000 --steps 1", "ulimit -v 300000; ");
  EXPECT_EQ(o.exit_code, 3) << o.output;
  EXPECT_NE(o.output.find("out of memory: an allocation failed"), std::string::npos) << o.output;
}

}  // namespace

namespace {

using namespace soda_cli_test;

// Joints run in one world and in territory worlds, bit-identical, with
// inputs, recording, checkpoints and the watchdog's heal
// (docs/scene-format.md, "Joints").
TEST_F(CliTest, JointScenesRunInEveryWorld) {
  std::string first;
  for (const char* seed : {"0", "3"}) {
    const Outcome o = run_cli(std::string("run --scene ragdolls --n 4 --steps 120 --shuffle-seed ") + seed);
    ASSERT_EQ(o.exit_code, 0) << o.output;
    if (first.empty()) first = hash_of(o);
    EXPECT_EQ(hash_of(o), first) << "seed " << seed;
  }
  EXPECT_EQ(run_cli("run --scene pendulums --n 4 --steps 30 --world stock").exit_code, 0);
  const Outcome one = run_cli("run --scene chain-bridge --n 8 --steps 60");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  for (const char* args : {"run --scene chain-bridge --n 8 --steps 60 --territories 2",
                           "run --scene chain-bridge --n 8 --steps 60 --territories 4 --anticipation 8",
                           "run --scene chain-bridge --n 8 --steps 60 --sync-test 4"}) {
    const Outcome o = run_cli(args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    EXPECT_EQ(hash_of(o), hash_of(one)) << args;
  }
  // Inputs (a kick, box 11 pinned to the ground, a hinge from plank 4 to
  // plank 6, the removal of plank 5 between them and, queued in the
  // checkpoint, of joint 5 between planks 7 and 8; through a Simulation
  // and, with --sync-test, through the PartitionedWorld), --record and a checkpoint
  // resumed on other territory counts: the one-territory hash with the
  // same inputs.
  const std::string inputs = (dir_ / "bridge-inputs.json").string();
  std::ofstream(inputs) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "apply_impulse", "step": 20, "id": 3, "impulse": [0, 40, 0]},
      {"type": "remove_body", "step": 35, "id": 5},
      {"type": "add_joint", "step": 10, "joint": {"id": 20, "type": "point-to-point", "body_a": 11, "body_b": 0,
          "frame_b": {"position": [0, 8, 0]}}},
      {"type": "add_joint", "step": 25, "joint": {"id": 21, "type": "hinge", "body_a": 4, "body_b": 6,
          "frame_a": {"position": [1, 0, 0]}, "frame_b": {"position": [-1, 0, 0]}}},
      {"type": "remove_joint", "step": 40, "joint": 5}]})";
  const std::string with = "run --scene chain-bridge --n 8 --steps 60 --log-level warn --inputs " + inputs;
  const Outcome plain = run_cli(with);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_NE(hash_of(plain), hash_of(one));
  const std::string ckpt = (dir_ / "bridge.ckpt").string(), replay = (dir_ / "bridge.replay").string();
  for (const std::string& args :
       {with + " --territories 2", with + " --territories 4 --anticipation 8", with + " --territories 2 --sync-test 2",
        with + " --territories 2 --record " + replay, with + " --territories 2 --checkpoint-at 30 --checkpoint " + ckpt,
        "run --resume " + ckpt + " --steps 60 --log-level warn --territories 4",
        "run --resume " + ckpt + " --steps 60 --log-level warn --territories 1"}) {
    const Outcome o = run_cli(args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    EXPECT_EQ(hash_of(o), hash_of(plain)) << args;
  }
  // A joint between the bridge's group and a free box: exit 2, named.
  const std::string joins = (dir_ / "bridge-joins.json").string();
  std::ofstream(joins) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "add_joint", "step": 10, "joint": {"id": 90, "type": "point-to-point", "body_a": 3, "body_b": 11}}]})";
  for (const char* k : {"1", "4"}) {
    const Outcome o = run_cli("run --scene chain-bridge --n 8 --steps 20 --territories " + std::string(k) + " --inputs " + joins);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    EXPECT_NE(o.output.find("add joint 90 at step 10: body_b: body 3 is in the joint group of body 3, body 11 is in "
                            "no joint group; a joint that joins two groups or free bodies cannot be added"),
              std::string::npos)
        << o.output;
  }
  // --watchdog heal: in steps of 0.65 s boxes sink more than 1 m into the planks; the heals are the same for 1
  // and 2 territories, and so is the hash.
  const std::string heal = "run --scene chain-bridge --n 12 --steps 60 --dt 0.65 --log-level warn --watchdog heal";
  const Outcome healed_one = run_cli(heal);
  ASSERT_EQ(healed_one.exit_code, 0) << healed_one.output;
  EXPECT_NE(healed_one.output.find("re-simulate step"), std::string::npos) << healed_one.output;
  const Outcome healed_two = run_cli(heal + " --territories 2");
  ASSERT_EQ(healed_two.exit_code, 0) << healed_two.output;
  EXPECT_EQ(hash_of(healed_two), hash_of(healed_one));
}

// Motor inputs from an input file (docs/inputs.md, "set_joint_motor"): the
// motor-hinge's free arm sped up and reversed, the limited one's motor off,
// on 1, 2 and 4 territories and across a checkpoint with one queued: one
// hash, not the run without them. A motor the joint does not have: exit 2,
// the joint and the field named.
TEST_F(CliTest, JointMotorInputsRunFromAFileAndBadOnesAreBadInput) {
  const std::string inputs = (dir_ / "motor-inputs.json").string();
  std::ofstream(inputs) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "set_joint_motor", "step": 10, "joint": 0, "velocity": 5, "max_impulse": 1},
      {"type": "set_joint_motor", "step": 20, "joint": 1, "on": false},
      {"type": "set_joint_motor", "step": 40, "joint": 0, "velocity": -3, "max_impulse": 2}]})";
  const Outcome none = run_cli("run --scene motor-hinge --steps 60");
  ASSERT_EQ(none.exit_code, 0) << none.output;
  const std::string with = "run --scene motor-hinge --steps 60 --log-level warn --inputs " + inputs;
  const Outcome one = run_cli(with);
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_NE(hash_of(one), hash_of(none));
  const std::string ckpt = (dir_ / "motor.ckpt").string();
  for (const std::string& args : {with + " --territories 2", with + " --territories 4 --anticipation 8",
                                  with + " --territories 2 --checkpoint-at 30 --checkpoint " + ckpt,
                                  "run --resume " + ckpt + " --steps 60 --log-level warn --territories 4"}) {
    const Outcome o = run_cli(args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    EXPECT_EQ(hash_of(o), hash_of(one)) << args;
  }
  const std::string bad = (dir_ / "bad-motor.json").string();
  std::ofstream(bad) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "set_joint_motor", "step": 10, "joint": 1, "velocity": 1, "max_impulse": 1, "axis": 5}]})";
  const Outcome refused = run_cli("run --scene motor-hinge --steps 20 --inputs " + bad);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("set the motor of joint 1 at step 10: axis: a hinge joint has one motor (no axis)"),
            std::string::npos)
      << refused.output;
}

// Collision filter inputs from an input file (docs/inputs.md,
// "set_collision_filter"): cubes of a pile made to pass through each other
// and one through the ground, on 1, 2 and 4 territories (speculating) and
// across a checkpoint with one queued: one hash, not the run without them.
// A static body's filter: exit 2, the body named.
TEST_F(CliTest, CollisionFilterInputsRunFromAFileAndBadOnesAreBadInput) {
  const std::string inputs = (dir_ / "filter-inputs.json").string();
  std::ofstream(inputs) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "set_collision_filter", "step": 20, "id": 4, "group": 16, "mask": 0},
      {"type": "set_collision_filter", "step": 30, "id": 6, "group": 16, "mask": 4294967279},
      {"type": "set_collision_filter", "step": 30, "id": 8, "group": 16, "mask": 4294967279},
      {"type": "set_collision_filter", "step": 50, "id": 6, "group": 1, "mask": 4294967295}]})";
  const std::string scene = "run --scene cube-pile --n 60 --steps 80";
  const Outcome none = run_cli(scene);
  ASSERT_EQ(none.exit_code, 0) << none.output;
  const std::string with = scene + " --log-level warn --inputs " + inputs;
  const Outcome one = run_cli(with);
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_NE(hash_of(one), hash_of(none));
  const std::string ckpt = (dir_ / "filter.ckpt").string();
  for (const std::string& args : {with + " --territories 2", with + " --territories 4 --anticipation 8",
                                  with + " --territories 2 --checkpoint-at 40 --checkpoint " + ckpt,
                                  "run --resume " + ckpt + " --steps 80 --log-level warn --territories 4"}) {
    const Outcome o = run_cli(args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    EXPECT_EQ(hash_of(o), hash_of(one)) << args;
  }
  const std::string bad = (dir_ / "bad-filter.json").string();
  std::ofstream(bad) << R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "set_collision_filter", "step": 20, "id": 0, "group": 16, "mask": 0}]})";
  const Outcome refused = run_cli(scene + " --inputs " + bad);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("set the collision filter of body 0 at step 20: the body is static"),
            std::string::npos)
      << refused.output;
}

// A bad joint in a scene file: exit 2, the joint and the field named.
TEST_F(CliTest, ABadJointIsBadInput) {
  const std::filesystem::path file = dir_ / "bad-joint.json";
  std::ofstream(file) << R"({"format": "soda-scene", "version": 1, "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
      {"id": 1, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 2, 0]}],
    "joints": [{"id": 4, "type": "hinge", "body_a": 1, "body_b": 12}]})";
  const Outcome o = run_cli("run --scene " + file.string() + " --steps 5");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("joint #0 (id 4): field 'body_b': no body with id 12"), std::string::npos) << o.output;
}

}  // namespace
