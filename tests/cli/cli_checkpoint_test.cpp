// `soda run --checkpoint-at STEP --checkpoint FILE` and `soda run --resume
// FILE --steps S` (docs/checkpoints.md): a run with inputs before and after
// the checkpoint, saved on 2 speculating territories, resumed on 1, 4 and 8
// territories with other partitions and schedules, ends on the
// uninterrupted hash; bad files and bad combinations are bad input (exit 2)
// with a message naming the file and the problem. An input log written by
// the embedding API replays with `soda run --inputs` to the API's hash.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli/cli_test_util.h"
#include "soda/runtime/simulation.h"

namespace {

using namespace soda_cli_test;

class CliCheckpoint : public CliTest {
 protected:
  const soda::Scene scene_ = soda::make_scene("cube-pile", {150, 1, false});
  std::string scene_args_ = "run --scene cube-pile --n 150 --seed 1 --log-level warn ";
  std::string run_ = scene_args_ + "--steps 150 ";
  std::vector<soda::UserInput> inputs_;

  void SetUp() override {
    CliTest::SetUp();
    soda::BodyId first = 0, added = 0;
    for (const soda::Body& b : scene_.bodies) {
      if (!b.is_static && first == 0) first = b.id;
      added = std::max(added, b.id + 1);
    }
    soda::UserInput add;
    add.kind = soda::UserInput::Kind::AddBody;
    add.step = 20;
    add.body.id = added;
    add.body.shape = soda::Shape::box(soda::Vec3::Constant(0.5));
    add.body.position = soda::Vec3(0.2, 10, -0.1);
    add.body.linear_velocity = soda::Vec3(0, -2, 0);
    soda::UserInput remove{.kind = soda::UserInput::Kind::RemoveBody, .step = 40, .id = first};
    soda::UserInput velocity{.kind = soda::UserInput::Kind::SetVelocity, .step = 50, .id = first + 1};
    velocity.linear = soda::Vec3(2, 5, 0);
    soda::UserInput impulse{.kind = soda::UserInput::Kind::ApplyImpulse, .step = 100, .id = added};
    impulse.linear = soda::Vec3(1, 6, 0);
    soda::UserInput late_remove{.kind = soda::UserInput::Kind::RemoveBody, .step = 120, .id = first + 2};
    inputs_ = {add, remove, velocity, impulse, late_remove};
  }
  std::string inputs_file() { return write("inputs.json", soda::inputs_to_json(inputs_)); }
};

TEST_F(CliCheckpoint, ResumeEndsOnTheUninterruptedHash) {
  const std::string in = inputs_file();
  const std::string ckpt = (dir_ / "at60.ckpt").string();
  const Outcome plain = run_cli(run_ + "--inputs " + in);
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  const Outcome saved =
      run_cli(run_ + "--inputs " + in + " --territories 2 --anticipation 8 --checkpoint-at 60 --checkpoint " + ckpt);
  ASSERT_EQ(saved.exit_code, 0) << saved.output;
  EXPECT_NE(saved.output.find("checkpoint at step 60: "), std::string::npos) << saved.output;
  EXPECT_EQ(hash_of(saved), hash_of(plain)) << saved.output;
  for (const char* how : {"--territories 1", "--territories 4 --partition rcb --threads 2",
                          "--territories 8 --anticipation 8", "--territories 4 --partition grid:4x1x1 --threads 1"}) {
    const Outcome resumed = run_cli("run --resume " + ckpt + " --steps 150 --log-level warn " + how);
    ASSERT_EQ(resumed.exit_code, 0) << how << "\n" << resumed.output;
    EXPECT_NE(resumed.output.find("resumed " + ckpt + " at step 60, ran to step 150"), std::string::npos)
        << resumed.output;
    std::printf("[ cube-pile 150, 5 inputs, saved at 60 on K 2 anticipation 8 ] uninterrupted %s, resumed with %s: "
                "%s\n",
                hash_of(plain).c_str(), how, hash_of(resumed).c_str());
    EXPECT_EQ(hash_of(resumed), hash_of(plain)) << how << "\n" << resumed.output;
  }
  // Resumed to an earlier step than the end: the hash of the run to there.
  const Outcome to100 = run_cli("run --resume " + ckpt + " --steps 100 --territories 4 --log-level warn");
  const Outcome plain100 = run_cli("run --scene cube-pile --n 150 --seed 1 --steps 100 --log-level warn --inputs " + in);
  ASSERT_EQ(to100.exit_code, 0) << to100.output;
  EXPECT_EQ(hash_of(to100), hash_of(plain100)) << to100.output;
}

TEST_F(CliCheckpoint, BadFilesAndOptionsAreBadInput) {
  const std::string ckpt = (dir_ / "c.ckpt").string();
  const Outcome saved = run_cli(scene_args_ + "--steps 40 --checkpoint-at 30 --checkpoint " + ckpt);
  ASSERT_EQ(saved.exit_code, 0) << saved.output;
  std::ifstream f(ckpt, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(f)), {});
  ASSERT_GT(bytes.size(), 100u);
  auto expect_refused = [&](const std::string& args, const std::string& needle) {
    const Outcome o = run_cli(args);
    EXPECT_EQ(o.exit_code, 2) << args << "\n" << o.output;
    EXPECT_NE(o.output.find(needle), std::string::npos) << args << "\n" << o.output;
  };
  const std::string cut = write("cut.ckpt", bytes.substr(0, bytes.size() / 2));
  expect_refused("run --resume " + cut, "checkpoint " + cut + ": truncated");
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 1;
  const std::string damaged = write("damaged.ckpt", flipped);
  expect_refused("run --resume " + damaged, "checkpoint " + damaged + ": damaged");
  std::string v13 = bytes;
  v13[8] = 13;
  const std::string version = write("v13.ckpt", v13);
  expect_refused("run --resume " + version, "format version 13; this build reads versions 1 to 12");
  const std::string scene_file = write("scene.json", R"({"format": "soda-scene", "version": 1, "bodies": []})");
  expect_refused("run --resume " + scene_file, "not a SODA checkpoint");
  expect_refused("run --resume " + (dir_ / "missing.ckpt").string(), "cannot open");
  expect_refused("run --resume " + ckpt + " --steps 20", "--steps 20: before step 30");
  expect_refused("run --resume " + ckpt + " --scene falling-cubes", "excludes");
  expect_refused(run_ + "--checkpoint-at 200 --checkpoint " + ckpt, "--checkpoint-at 200: outside the run's steps");
  expect_refused(run_ + "--checkpoint " + ckpt, "requires --checkpoint-at");
  expect_refused(run_ + "--checkpoint-at 30 --checkpoint " + (dir_ / "no/such/dir.ckpt").string(), "cannot write");
  expect_refused(run_ + "--checkpoint-at 30 --checkpoint " + ckpt + " --sync-test 2",
                 "the run must go through a Simulation, which does not support --sync-test");
}

#ifdef SODA_OTHER_CLI_PATH
// A checkpoint of the other precision's build (soda vs soda-double) is
// refused by name, never misread.
TEST_F(CliCheckpoint, OtherPrecisionIsRefused) {
  const std::string ckpt = (dir_ / "other.ckpt").string();
  const std::string cmd = std::string(SODA_OTHER_CLI_PATH) + " " + scene_args_ + "--steps 20 --checkpoint-at 10 --checkpoint " +
                          ckpt + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Outcome o = run_cli("run --resume " + ckpt);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  const bool double_build = std::string(SODA_CLI_PATH).ends_with("-double");
  EXPECT_NE(o.output.find(double_build ? "written by a float-precision build" : "written by a double-precision build"),
            std::string::npos)
      << o.output;
  std::printf("%s", o.output.c_str());
}
#endif

// The embedding API's input log (Simulation::write_input_log), replayed by
// `soda run --inputs`: the API's hash, on another territory count.
TEST_F(CliCheckpoint, InputLogReplaysToTheApiHash) {
  soda::Simulation sim(scene_, soda::SimulationConfig{.territories = 2});
  for (const soda::UserInput& in : inputs_) {
    const double t = sim.time_of(in.step);
    switch (in.kind) {
      case soda::UserInput::Kind::AddBody: sim.add_body(t, in.body); break;
      case soda::UserInput::Kind::RemoveBody: sim.remove_body(t, in.id); break;
      case soda::UserInput::Kind::SetVelocity: sim.set_velocity(t, in.id, in.linear, in.angular); break;
      case soda::UserInput::Kind::ApplyImpulse: sim.apply_impulse(t, in.id, in.linear); break;
    }
  }
  ASSERT_TRUE(sim.advance_to(sim.time_of(150)));
  const std::string log = (dir_ / "log.json").string();
  sim.write_input_log(log);
  const Outcome o = run_cli(run_ + "--inputs " + log + " --territories 4");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  char api[17];
  std::snprintf(api, sizeof api, "%016llx", static_cast<unsigned long long>(sim.state_hash()));
  std::printf("[ cube-pile 150, %zu inputs ] API on K 2 %s, its log replayed by soda run on K 4 %s\n", inputs_.size(),
              api, hash_of(o).c_str());
  EXPECT_EQ(hash_of(o), api) << o.output;
}

}  // namespace
