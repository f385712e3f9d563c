// Joint inputs (docs/embedding.md, "Joints"; docs/inputs.md): remove_joint
// on the registry's pendulums, chain-bridge and ragdolls under the game
// loop — queued before the run, given at the frame on screen (a rollback)
// and given ahead while the worlds run, mixed with a body removal in what a
// joint removal split off. Every frame the render thread reads and the
// final hash equal the one-territory run with every input queued before it,
// for K = 1, 2, 4, lockstep and anticipation 8; the same under SyncTest and
// validation, from the input file format, and across a checkpoint with a
// removal queued. Refused removals name the joint and the field and leave
// nothing applied. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "driver/testing_hooks.h"
#include "runtime/simulation_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/scene/input_file.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 120;
constexpr BodyId kAny = ~BodyId{0};

// The smallest id of a joint joining `a` and `b` (kAny: any body); the test
// fails if there is none.
JointId joint_between(const Scene& s, BodyId a, BodyId b) {
  for (const Joint& j : s.joints)
    if ((j.body_a == a && (b == kAny || j.body_b == b)) || (j.body_b == a && (b == kAny || j.body_a == b)))
      return j.id;
  ADD_FAILURE() << s.name << ": no joint joins bodies " << a << " and " << b;
  return 0;
}

struct JointScene {
  const char* name;
  int n;
  // The joints' ends (kAny: the first joint of the first body), in plan()'s order.
  BodyId ahead[2], at_frame[2], given_ahead[2], late[2];
  BodyId removed_body;  // in the part `ahead` split off, removed at the frame on screen
};

// pendulums 8: chain c hangs links 2 + 9c .. 9 + 9c from static anchor 1 +
// 9c. Joint 5-6 goes (links 6..9 fall, a group anchored at 6), chain 1's
// joint to its anchor (the whole chain falls), joint 22-23 in chain 2; link
// 7 goes; late, joint 32-33 of chain 3. chain-bridge 12: planks 3..14 hinged between pillars 1 and 2.
// Joint 8-9 goes (9..14 anchored at 9, on the other side of the scene),
// then the left pillar's joint to plank 3, then plank 14's to the right
// pillar; plank 11 goes; late, joint 5-6. ragdolls 4: ragdoll r is bodies 1 + 11r .. 11 + 11r,
// pelvis first; a joint of ragdoll 1's pelvis, of ragdoll 2's and of
// ragdoll 3's go; body 13 goes; late, a joint of ragdoll 0's spine, in
// the pile (its island the same bodies after it: only the joint tells).
// The late removals are at the frame on screen: a re-run of steps whose
// islands the run it repeats solved with the joint.
const std::vector<JointScene>& joint_scenes() {
  static const std::vector<JointScene> all = {
      {"pendulums", 8, {5, 6}, {10, 11}, {22, 23}, {32, 33}, 7},
      {"chain-bridge", 12, {8, 9}, {1, 3}, {14, 2}, {5, 6}, 11},
      {"ragdolls", 4, {12, kAny}, {23, kAny}, {34, kAny}, {2, kAny}, 13},
  };
  return all;
}

const Scene& scene_of(const JointScene& j) {
  static std::map<std::string, Scene> made;
  auto it = made.find(j.name);
  if (it == made.end()) it = made.emplace(j.name, test::scene(j.name, j.n)).first;
  return it->second;
}

UserInput remove_joint(std::int64_t step, JointId joint) {
  UserInput in;
  in.kind = UserInput::Kind::RemoveJoint;
  in.step = step;
  in.joint = joint;
  return in;
}

UserInput remove_body(std::int64_t step, BodyId id) {
  UserInput in;
  in.kind = UserInput::Kind::RemoveBody;
  in.step = step;
  in.id = id;
  return in;
}

std::vector<test::PlannedInput> plan(const JointScene& j) {
  const Scene& s = scene_of(j);
  return {
      {remove_joint(15, joint_between(s, j.ahead[0], j.ahead[1]))},
      {remove_joint(30, joint_between(s, j.at_frame[0], j.at_frame[1])), true},
      {remove_body(45, j.removed_body), true},
      {remove_joint(70, joint_between(s, j.given_ahead[0], j.given_ahead[1])), false, 50},
      {remove_joint(90, joint_between(s, j.late[0], j.late[1])), true},
  };
}

const test::QueuedRun& reference(const JointScene& j) {
  static std::map<std::string, test::QueuedRun> made;
  auto it = made.find(j.name);
  if (it == made.end()) it = made.emplace(j.name, test::queued_run(scene_of(j), plan(j), kSteps)).first;
  return it->second;
}

// scene, territories, anticipation
class JointInputs : public ::testing::TestWithParam<std::tuple<int, int, int>> {};

TEST_P(JointInputs, EveryFrameWithJointsRemovedEqualsOneTerritory) {
  const auto [scene_index, territories, anticipation] = GetParam();
  const JointScene& j = joint_scenes()[static_cast<std::size_t>(scene_index)];
  const Scene& s = scene_of(j);
  const test::QueuedRun& ref = reference(j);

  test::Progress progress;
  SimulationConfig config{.territories = territories, .buffer_capacity = 16, .past_inputs = true};
  config.runtime.anticipation = anticipation;
  config.after_step = progress.hook();
  // A re-run's replayed islands are solved too and compared: an island
  // replayed with the joints of the run it repeats would throw.
  detail::edit_testing_hooks(config).verify_replay = true;
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  const test::RenderedRun run = test::run_game_loop(sim, reader, progress, plan(j), ref.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  const std::size_t joints = sim.snapshot().state.joints.size();
  sim.stop();
  std::printf("[ %s %d %s, K %d, anticipation %d ] %llu rollbacks; %zu of %zu joints at step %d; hash %s, one "
              "territory %s\n",
              j.name, j.n, kPrecisionName, territories, anticipation, static_cast<unsigned long long>(sim.rollbacks()),
              joints, s.joints.size(), kSteps, hash_hex(hash).c_str(), hash_hex(ref.hash).c_str());
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(sim.rollbacks(), run.at_frame);
  // Four joints removed, and the removed body's (it had one or two left).
  EXPECT_LT(joints, s.joints.size() - 4);
  EXPECT_EQ(run.bodies.at(0), s.dynamic_count());
  EXPECT_EQ(run.bodies.at(kSteps), s.dynamic_count() - 1);
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
}

std::vector<std::tuple<int, int, int>> cases() {
  std::vector<std::tuple<int, int, int>> out;
  for (int scene = 0; scene < 3; ++scene)
    for (int k : {1, 2, 4})
      for (int anticipation : {0, 8}) out.emplace_back(scene, k, anticipation);
  return out;
}

INSTANTIATE_TEST_SUITE_P(Simulation, JointInputs, ::testing::ValuesIn(cases()), [](const auto& info) {
  std::string name = std::string(joint_scenes()[static_cast<std::size_t>(std::get<0>(info.param))].name) + "_K" +
                     std::to_string(std::get<1>(info.param)) + "_anticipation" + std::to_string(std::get<2>(info.param));
  for (char& ch : name)
    if (ch == '-') ch = '_';
  return name;
});

// A removed joint changes the run: without the removals the hash differs
// (the test above could not pass by the input doing nothing).
TEST(JointInputScenes, ARemovedJointChangesTheRun) {
  for (const JointScene& j : joint_scenes()) {
    Simulation sim(scene_of(j), SimulationConfig{.territories = 1});
    sim.remove_body(sim.time_of(45), j.removed_body);
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    EXPECT_NE(hash_hex(sim.state_hash()), hash_hex(reference(j).hash)) << j.name;
    sim.stop();
  }
}

// The plan through the input file format, given before the run to a
// PartitionedWorld that checks ownership every step under SyncTest (every
// step restored from its snapshot and re-run): the Simulation's hash.
TEST(JointInputScenes, FromTheInputFileUnderSyncTestAndValidation) {
  for (const JointScene& j : joint_scenes()) {
    std::vector<UserInput> planned;
    for (const test::PlannedInput& i : plan(j)) planned.push_back(i.input);
    const std::vector<UserInput> inputs = parse_inputs_json(inputs_to_json(planned), "log");
    ASSERT_EQ(inputs.size(), planned.size());
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      EXPECT_EQ(inputs[i].kind, planned[i].kind);
      EXPECT_EQ(inputs[i].joint, planned[i].joint);
    }
    for (int anticipation : {0, 8}) {
      PartitionedOptions o;
      o.runtime.validate = true;
      o.runtime.anticipation = anticipation;
      o.sync_test = 1;
      o.inputs = inputs;
      PartitionedWorld w(scene_of(j), make_partition("kmeans", scene_of(j), 4, GridOptions{}), o);
      w.step(kSteps);
      std::printf("[ %s %d %s, K 4, sync-test 1, anticipation %d ] %llu sync rollbacks; %s, Simulation %s\n", j.name,
                  j.n, kPrecisionName, anticipation, static_cast<unsigned long long>(w.sync_rollbacks()),
                  hash_hex(w.state_hash()).c_str(), hash_hex(reference(j).hash).c_str());
      EXPECT_GT(w.sync_rollbacks(), 0u);
      EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference(j).hash)) << j.name << " anticipation " << anticipation;
    }
  }
}

// A removal queued in a checkpoint: the bridge saved at step 40 on 2
// territories with joint 8-9 removed at 15 and the right pillar's joint
// queued for 70, resumed on 1 and on 4 speculating: the uninterrupted hash
// at step 120. Version 8 cannot hold a joint input.
TEST(JointInputScenes, CheckpointsCarryAQueuedRemoval) {
  const JointScene& j = joint_scenes()[1];
  const Scene& s = scene_of(j);
  auto inputs = [&](Simulation& sim) {
    sim.remove_joint(sim.time_of(15), joint_between(s, 8, 9));
    sim.remove_joint(sim.time_of(70), joint_between(s, 14, 2));
  };
  Simulation whole(s, SimulationConfig{.territories = 1});
  inputs(whole);
  EXPECT_TRUE(whole.advance_to(whole.time_of(kSteps)));
  const std::string expected = hash_hex(whole.state_hash());
  whole.stop();

  Simulation sim(s, SimulationConfig{.territories = 2});
  inputs(sim);
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-joint-inputs.ckpt").string();
  EXPECT_EQ(sim.save(path), 40);
  sim.stop();
  const SimulationSnapshot back = read_checkpoint(path);
  EXPECT_EQ(back.state.joints.size(), s.joints.size() - 1);
  ASSERT_EQ(back.inputs.size(), 1u);
  EXPECT_EQ(back.inputs[0].kind, UserInput::Kind::RemoveJoint);
  EXPECT_EQ(back.inputs[0].joint, joint_between(s, 14, 2));
  try {
    encode_checkpoint(back, 8);
    ADD_FAILURE() << "version 8 took a joint input";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 8 cannot hold the input to remove joint"), std::string::npos)
        << e.what();
  }
  for (int k : {1, 4}) {
    SimulationConfig config{.territories = k};
    config.runtime.anticipation = k > 1 ? 8 : 0;
    Simulation resumed = Simulation::resume(path, config);
    // The joint removed before the snapshot is unknown to the resumed run.
    EXPECT_THROW(resumed.remove_joint(resumed.time_of(50), joint_between(s, 8, 9)), std::invalid_argument);
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
    std::printf("[ chain-bridge 12 %s ] resumed at step 40 on %d: %s, uninterrupted %s\n", kPrecisionName, k,
                hash_hex(resumed.state_hash()).c_str(), expected.c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), expected) << "K=" << k;
    resumed.stop();
  }
  std::filesystem::remove(path);
}

void expect_refused(const std::function<void()>& call, const std::vector<std::string>& needles) {
  try {
    call();
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    std::printf("refused: %s\n", e.what());
    for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
  }
}

// Refusals name the joint and the field, and nothing of them is applied:
// the run with them refused is the run with only the accepted inputs.
TEST(JointInputScenes, RefusalsNameTheJointAndApplyNothing) {
  const JointScene& j = joint_scenes()[0];
  const Scene& s = scene_of(j);
  const JointId j56 = joint_between(s, 5, 6), j1011 = joint_between(s, 10, 11);
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.remove_joint(sim.time_of(20), j56);
  sim.remove_body(sim.time_of(10), 22);
  expect_refused([&] { sim.remove_joint(sim.time_of(5), 999999); },
                 {"remove joint 999999 at step 5", "joint: no joint has that id"});
  expect_refused([&] { sim.remove_joint(sim.time_of(30), j56); },
                 {"remove joint " + std::to_string(j56) + " at step 30", "joint:", "removed at step 20 already"});
  expect_refused([&] { sim.remove_joint(sim.time_of(5), j56); }, {"removed at step 20 already"});
  // Joint 22-23 went with body 22 at step 10 (not before).
  const JointId j2223 = joint_between(s, 22, 23);
  expect_refused([&] { sim.remove_joint(sim.time_of(12), j2223); }, {"gone then, with body 22", "step 10"});
  expect_refused([&] { sim.remove_joint(sim.time_of(10), j2223); }, {"gone then, with body 22"});
  // Body 6 cannot go before the joint removal queued for it.
  expect_refused([&] { sim.remove_body(sim.time_of(19), 6); }, {"remove body 6 at step 19", "later step 20"});
  expect_refused([&] { sim.remove_joint(-1.0, j1011); }, {"must be >= 0"});
  sim.remove_joint(sim.time_of(9), j2223);  // before its body goes: accepted
  sim.remove_body(sim.time_of(20), 6);      // at the joint's step, after it: accepted
  const std::vector<UserInput> log = sim.input_log();
  ASSERT_EQ(log.size(), 4u);
  EXPECT_TRUE(sim.advance_to(sim.time_of(60)));
  Simulation clean(s, SimulationConfig{.territories = 1});
  clean.remove_joint(clean.time_of(20), j56);
  clean.remove_body(clean.time_of(10), 22);
  clean.remove_joint(clean.time_of(9), j2223);
  clean.remove_body(clean.time_of(20), 6);
  EXPECT_TRUE(clean.advance_to(clean.time_of(60)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(clean.state_hash()));
  EXPECT_EQ(sim.snapshot().state.joints.size(), s.joints.size() - 4);  // 5-6, 22-23, 21-22, 6-7
  sim.stop();
  clean.stop();
}

TEST(JointInputScenes, InputFileRefusesABadJointField) {
  auto refused = [](const std::string& entry, const std::vector<std::string>& needles) {
    const std::string text = R"({"format": "soda-inputs", "version": 1, "inputs": [)" + entry + "]}";
    try {
      parse_inputs_json(text, "bad.json");
      ADD_FAILURE() << "accepted: " << entry;
    } catch (const SceneError& e) {
      std::printf("refused: %s\n", e.what());
      for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  };
  refused(R"({"type": "remove_joint", "step": 3})", {"remove_joint at step 3", "'joint'", "missing"});
  refused(R"({"type": "remove_joint", "step": 3, "joint": -1})", {"'joint'", "[0, 2^31)"});
  refused(R"({"type": "remove_joint", "step": 3, "joint": 2, "id": 4})", {"'id'"});
  const std::vector<UserInput> ok =
      parse_inputs_json(R"({"format": "soda-inputs", "version": 1, "inputs": [{"type": "remove_joint", "step": 3,
          "joint": 2147483647}]})", "ok.json");
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok[0].kind, UserInput::Kind::RemoveJoint);
  EXPECT_EQ(ok[0].joint, kMaxJointId);
}

}  // namespace
}  // namespace soda
