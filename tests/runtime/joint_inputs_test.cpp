// Joint inputs (docs/embedding.md, "Joints"; docs/inputs.md): remove_joint
// and add_joint on the registry's pendulums, chain-bridge and ragdolls under the game
// loop — queued before the run, given at the frame on screen (a rollback)
// and given ahead while the worlds run, mixed with a body removal in what a
// joint removal split off. Every frame the render thread reads and the
// final hash equal the one-territory run with every input queued before it,
// for K = 1, 2, 4, lockstep and anticipation 8; the same under SyncTest and
// validation, from the input file format, and across a checkpoint with a
// removal queued. Refused removals name the joint and the field and leave
// nothing applied. Added joints (a body pinned to a static one, a loop
// closed in one joint group) the same way. Label "concurrency"
// (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
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

  // A re-run's replayed islands are solved too and compared: an island
  // replayed with the joints of the run it repeats would throw.
  test::GameLoop loop(s, territories, anticipation, true);
  Simulation& sim = loop.sim;
  const test::RenderedRun run = loop.run(plan(j), ref.frames, kSteps);
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
    if (test::kThreadSanitizer && std::string(j.name) != "ragdolls") continue;  // one scene under TSan
    std::vector<UserInput> planned;
    for (const test::PlannedInput& i : plan(j)) planned.push_back(i.input);
    const std::vector<UserInput> inputs = parse_inputs_json(inputs_to_json(planned), "log");
    ASSERT_EQ(inputs.size(), planned.size());
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      EXPECT_EQ(inputs[i].kind, planned[i].kind);
      EXPECT_EQ(inputs[i].joint, planned[i].joint);
    }
    for (int anticipation : test::sync_test_anticipations()) {
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
// at step 120. The removed joint's id stays retired: no input names it and
// no added joint takes it, as in the uninterrupted run. Version 8 cannot
// hold a joint input, version 10 the retired joint ids.
TEST(JointInputScenes, CheckpointsCarryAQueuedRemoval) {
  const JointScene& j = joint_scenes()[1];
  const Scene& s = scene_of(j);
  auto inputs = [&](Simulation& sim) {
    sim.remove_joint(sim.time_of(15), joint_between(s, 8, 9));
    sim.remove_joint(sim.time_of(70), joint_between(s, 14, 2));
  };
  Simulation whole(s, SimulationConfig{.territories = 1});
  inputs(whole);
  Joint reused;
  reused.id = joint_between(s, 8, 9);
  reused.body_a = 8;
  reused.body_b = 9;
  test::expect_refused([&] { whole.add_joint(whole.time_of(50), reused); }, {"is in use", "never used again"});
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
  const JointId removed = joint_between(s, 8, 9);
  EXPECT_EQ(back.retired_joint_ids, std::vector<JointId>{removed});
  try {
    encode_checkpoint(back, 10);
    ADD_FAILURE() << "version 10 took retired joint ids";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 10 cannot hold the ids of joints removed before its step (joint " +
                                         std::to_string(removed)),
              std::string::npos)
        << e.what();
  }
  Joint again;  // a new joint given the removed one's id
  again.id = removed;
  again.body_a = 8;
  again.body_b = 9;
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
    // The joint removed before the snapshot: retired in the resumed run.
    test::expect_refused([&] { resumed.remove_joint(resumed.time_of(50), removed); },
                         {"joint " + std::to_string(removed), "removed before the snapshot"});
    test::expect_refused([&] { resumed.add_joint(resumed.time_of(50), again); },
                         {"id: joint " + std::to_string(removed) + " is in use", "never used again"});
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
    std::printf("[ chain-bridge 12 %s ] resumed at step 40 on %d: %s, uninterrupted %s\n", kPrecisionName, k,
                hash_hex(resumed.state_hash()).c_str(), expected.c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), expected) << "K=" << k;
    resumed.stop();
  }
  std::filesystem::remove(path);
}

using test::expect_refused;

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
  const auto refused = test::expect_input_file_refused;
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

// --- add_joint ---------------------------------------------------------------

const Body& body_of(const Scene& s, BodyId id) {
  for (const Body& b : s.bodies)
    if (b.id == id) return b;
  ADD_FAILURE() << s.name << ": no body " << id;
  return s.bodies.front();
}

// A joint about `pivot`, given in the world at the bodies' start poses (as
// the registry's joint scenes give theirs).
Joint joint_at(const Scene& s, JointId id, JointKind kind, BodyId a, BodyId b, const Vec3& pivot) {
  Joint j;
  j.id = id;
  j.kind = kind;
  j.body_a = a, j.body_b = b;
  for (auto [body, frame] : {std::pair{a, &j.frame_a}, std::pair{b, &j.frame_b}}) {
    const Body& at = body_of(s, body);
    const Quat inv = at.orientation.normalized().conjugate();
    frame->position = inv * (pivot - at.position);
    frame->orientation = inv.normalized();
  }
  return j;
}

// A body pinned where it starts to a static one (point-to-point).
Joint pin(const Scene& s, JointId id, BodyId body, BodyId to) {
  return joint_at(s, id, JointKind::PointToPoint, body, to, body_of(s, body).position);
}

// Two bodies of one joint group joined half-way between their start
// positions: a loop closed.
Joint loop(const Scene& s, JointId id, JointKind kind, BodyId a, BodyId b) {
  return joint_at(s, id, kind, a, b, 0.5 * (body_of(s, a).position + body_of(s, b).position));
}

UserInput add_joint(std::int64_t step, const Joint& joint) {
  UserInput in;
  in.kind = UserInput::Kind::AddJoint;
  in.step = step;
  in.joint = joint.id;
  in.added_joint = joint;
  return in;
}

constexpr JointId kPin = 1000, kLoop = 1001, kLater = 1002;

// pendulums 8: the end of chain 0 (link 9) pinned to the ground where it
// starts; a loop in chain 1 (links 11 and 14); link 26 of chain 2 pinned to
// its anchor 19. chain-bridge 12: box 15 pinned to the ground in the air;
// a hinge from plank 4 to plank 6; plank 10 pinned to the right pillar.
// ragdolls 4: ragdoll 0's head pinned to the ground; its left lower arm
// joined to its left lower leg; ragdoll 2's pelvis pinned to the ground.
// The loop is removed again at 90, at the frame on screen.
std::vector<test::PlannedInput> add_plan(const JointScene& j) {
  const Scene& s = scene_of(j);
  const std::string name = j.name;
  Joint first, second, third;
  if (name == "pendulums") {
    first = pin(s, kPin, 9, 0), second = loop(s, kLoop, JointKind::PointToPoint, 11, 14), third = pin(s, kLater, 26, 19);
  } else if (name == "chain-bridge") {
    first = pin(s, kPin, 15, 0), second = loop(s, kLoop, JointKind::Hinge, 4, 6), third = pin(s, kLater, 10, 2);
  } else {
    first = pin(s, kPin, 3, 0), second = loop(s, kLoop, JointKind::PointToPoint, 10, 6), third = pin(s, kLater, 23, 0);
  }
  return {
      {add_joint(15, first)},
      {add_joint(30, second), true},
      {add_joint(70, third), false, 50},
      {remove_joint(90, kLoop), true},
  };
}

const test::QueuedRun& add_reference(const JointScene& j) {
  static std::map<std::string, test::QueuedRun> made;
  auto it = made.find(j.name);
  if (it == made.end()) it = made.emplace(j.name, test::queued_run(scene_of(j), add_plan(j), kSteps)).first;
  return it->second;
}

class JointAdds : public ::testing::TestWithParam<std::tuple<int, int, int>> {};

TEST_P(JointAdds, EveryFrameWithJointsAddedEqualsOneTerritory) {
  const auto [scene_index, territories, anticipation] = GetParam();
  const JointScene& j = joint_scenes()[static_cast<std::size_t>(scene_index)];
  const Scene& s = scene_of(j);
  const test::QueuedRun& ref = add_reference(j);

  test::GameLoop loop(s, territories, anticipation, true);
  Simulation& sim = loop.sim;
  const test::RenderedRun run = loop.run(add_plan(j), ref.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  const std::vector<JointSnapshot> joints = sim.snapshot().state.joints;
  sim.stop();
  std::printf("[ %s %d %s, K %d, anticipation %d ] %llu rollbacks; %zu joints at step %d (scene %zu); hash %s, one "
              "territory %s\n",
              j.name, j.n, kPrecisionName, territories, anticipation, static_cast<unsigned long long>(sim.rollbacks()),
              joints.size(), kSteps, s.joints.size(), hash_hex(hash).c_str(), hash_hex(ref.hash).c_str());
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(sim.rollbacks(), run.at_frame);
  // The two pins held, the loop removed again.
  ASSERT_EQ(joints.size(), s.joints.size() + 2);
  EXPECT_EQ(joints[joints.size() - 2].description.id, kPin);
  EXPECT_EQ(joints.back().description.id, kLater);
  EXPECT_EQ(run.bodies.at(kSteps), s.dynamic_count());
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
}

INSTANTIATE_TEST_SUITE_P(Simulation, JointAdds, ::testing::ValuesIn(cases()), [](const auto& info) {
  std::string name = std::string(joint_scenes()[static_cast<std::size_t>(std::get<0>(info.param))].name) + "_K" +
                     std::to_string(std::get<1>(info.param)) + "_anticipation" + std::to_string(std::get<2>(info.param));
  for (char& ch : name)
    if (ch == '-') ch = '_';
  return name;
});

// Each added joint changes the run: without it the hash differs.
TEST(JointAddScenes, AnAddedJointChangesTheRun) {
  for (const JointScene& j : joint_scenes()) {
    const std::vector<test::PlannedInput> all = add_plan(j);
    for (std::size_t left_out = 0; left_out < 3; ++left_out) {
      std::vector<test::PlannedInput> some;
      for (std::size_t i = 0; i < all.size(); ++i)
        if (i != left_out && !(left_out == 1 && i == 3)) some.push_back(all[i]);  // the loop's removal with it
      EXPECT_NE(hash_hex(test::queued_run(scene_of(j), some, kSteps).hash), hash_hex(add_reference(j).hash))
          << j.name << " without joint " << all[left_out].input.joint;
    }
  }
}

// The plan through the input file format (every field of the joints read
// back bit for bit), given before the run to a PartitionedWorld under
// SyncTest and validation: the Simulation's hash.
TEST(JointAddScenes, FromTheInputFileUnderSyncTestAndValidation) {
  for (const JointScene& j : joint_scenes()) {
    if (test::kThreadSanitizer && std::string(j.name) != "ragdolls") continue;  // one scene under TSan
    std::vector<UserInput> planned;
    for (const test::PlannedInput& i : add_plan(j)) planned.push_back(i.input);
    const std::vector<UserInput> inputs = parse_inputs_json(inputs_to_json(planned), "log");
    ASSERT_EQ(inputs.size(), planned.size());
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      EXPECT_EQ(inputs[i].kind, planned[i].kind);
      EXPECT_EQ(inputs[i].joint, planned[i].joint);
      const Joint &a = inputs[i].added_joint, &b = planned[i].added_joint;
      EXPECT_TRUE(a.kind == b.kind && a.body_a == b.body_a && a.body_b == b.body_b &&
                  a.frame_a.position == b.frame_a.position && a.frame_b.position == b.frame_b.position &&
                  a.frame_a.orientation.coeffs() == b.frame_a.orientation.coeffs() &&
                  a.frame_b.orientation.coeffs() == b.frame_b.orientation.coeffs())
          << j.name << " input " << i;
    }
    for (int anticipation : test::sync_test_anticipations()) {
      PartitionedOptions o;
      o.runtime.validate = true;
      o.runtime.anticipation = anticipation;
      o.sync_test = 1;
      o.inputs = inputs;
      PartitionedWorld w(scene_of(j), make_partition("kmeans", scene_of(j), 4, GridOptions{}), o);
      w.step(kSteps);
      std::printf("[ %s %d %s, K 4, sync-test 1, anticipation %d ] joints added: %s, Simulation %s\n", j.name, j.n,
                  kPrecisionName, anticipation, hash_hex(w.state_hash()).c_str(),
                  hash_hex(add_reference(j).hash).c_str());
      EXPECT_GT(w.sync_rollbacks(), 0u);
      EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(add_reference(j).hash)) << j.name << " anticipation " << anticipation;
    }
  }
}

// An addition queued in a checkpoint: the bridge saved at step 40 on 2
// territories with box 15 pinned at 15 and the plank 4-6 hinge queued for
// 70, resumed on 1 and on 4 speculating: the uninterrupted hash. Version 9
// cannot hold an add_joint input.
TEST(JointAddScenes, CheckpointsCarryAQueuedAddition) {
  const JointScene& j = joint_scenes()[1];
  const Scene& s = scene_of(j);
  auto inputs = [&](Simulation& sim) {
    sim.add_joint(sim.time_of(15), pin(s, kPin, 15, 0));
    sim.add_joint(sim.time_of(70), loop(s, kLoop, JointKind::Hinge, 4, 6));
  };
  Simulation whole(s, SimulationConfig{.territories = 1});
  inputs(whole);
  EXPECT_TRUE(whole.advance_to(whole.time_of(kSteps)));
  const std::string expected = hash_hex(whole.state_hash());
  whole.stop();

  Simulation sim(s, SimulationConfig{.territories = 2});
  inputs(sim);
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-joint-adds.ckpt").string();
  EXPECT_EQ(sim.save(path), 40);
  sim.stop();
  const SimulationSnapshot back = read_checkpoint(path);
  EXPECT_EQ(back.state.joints.size(), s.joints.size() + 1);
  ASSERT_EQ(back.inputs.size(), 1u);
  EXPECT_EQ(back.inputs[0].kind, UserInput::Kind::AddJoint);
  EXPECT_EQ(back.inputs[0].added_joint.id, kLoop);
  EXPECT_EQ(back.inputs[0].added_joint.kind, JointKind::Hinge);
  EXPECT_EQ(back.inputs[0].added_joint.frame_b.position, loop(s, kLoop, JointKind::Hinge, 4, 6).frame_b.position);
  try {
    encode_checkpoint(back, 9);
    ADD_FAILURE() << "version 9 took an add_joint input";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 9 cannot hold the input to add joint 1001"), std::string::npos)
        << e.what();
  }
  for (int k : {1, 4}) {
    SimulationConfig config{.territories = k};
    config.runtime.anticipation = k > 1 ? 8 : 0;
    Simulation resumed = Simulation::resume(path, config);
    // Joint 1000 is in the snapshot, 1001 queued: neither id is free.
    expect_refused([&] { resumed.add_joint(resumed.time_of(50), pin(s, kPin, 16, 0)); }, {"id: joint 1000 is in use"});
    expect_refused([&] { resumed.add_joint(resumed.time_of(50), pin(s, kLoop, 16, 0)); }, {"id: joint 1001 is in use"});
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
    std::printf("[ chain-bridge 12 %s ] joints added, resumed at step 40 on %d: %s, uninterrupted %s\n",
                kPrecisionName, k, hash_hex(resumed.state_hash()).c_str(), expected.c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), expected) << "K=" << k;
    resumed.stop();
  }
  std::filesystem::remove(path);
}

// Refusals name the joint and the field, and nothing of them is applied:
// the run with them refused is the run of the input log (the accepted
// inputs) on one territory.
TEST(JointAddScenes, RefusalsNameTheJointAndApplyNothing) {
  const JointScene& j = joint_scenes()[0];
  const Scene& s = scene_of(j);
  const JointId j56 = joint_between(s, 5, 6), j1213 = joint_between(s, 12, 13);
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.remove_joint(sim.time_of(20), j56);
  sim.remove_body(sim.time_of(10), 22);
  sim.add_joint(sim.time_of(40), loop(s, kLoop, JointKind::PointToPoint, 11, 14));  // chain 1: one group
  Body extra = body_of(s, 9);  // a free body, pinned to the ground
  extra.id = 500;
  extra.position += Vec3(0.0, 0.0, -3.0);
  sim.add_body(sim.time_of(5), extra);
  sim.add_joint(sim.time_of(5), pin(s, kPin, 9, 0));
  Joint to_extra = pin(s, kLater, 9, 0);
  to_extra.body_a = 500;
  sim.add_joint(sim.time_of(8), to_extra);

  auto at = [&](JointId id) { return "add joint " + std::to_string(id) + " at step "; };
  // Two groups (chains 0 and 1), a group and a free body, two free bodies.
  expect_refused([&] { sim.add_joint(sim.time_of(40), loop(s, 90, JointKind::PointToPoint, 5, 14)); },
                 {at(90) + "40: body_b: body 5 is in the joint group of body 2, body 14 is in the joint group of body "
                           "11; a joint that joins two groups or free bodies cannot be added while the worlds run",
                  "docs/embedding.md"});
  expect_refused([&] { sim.add_joint(sim.time_of(40), loop(s, 90, JointKind::Hinge, 2, 11)); },
                 {at(90) + "40: body_b: body 2 is in the joint group of body 2, body 11 is in the joint group of "
                           "body 11"});
  // Joint 5-6 is gone at 20: links 6..9 are a group of their own, anchored at 6.
  expect_refused([&] { sim.add_joint(sim.time_of(25), loop(s, 91, JointKind::PointToPoint, 4, 7)); },
                 {at(91) + "25: body_b: body 4 is in the joint group of body 2, body 7 is in the joint group of body 6"});
  sim.add_joint(sim.time_of(19), loop(s, 92, JointKind::PointToPoint, 4, 7));  // before the removal: one group
  Body other = extra;
  other.id = 501;
  other.position += Vec3(0.0, 0.0, -1.0);
  sim.add_body(sim.time_of(6), other);
  Joint free = pin(s, 93, 9, 0);
  free.body_a = 500, free.body_b = 501;  // 500 is pinned to the ground: in no group
  expect_refused([&] { sim.add_joint(sim.time_of(9), free); },
                 {at(93) + "9: body_b: body 500 is in no joint group, body 501 is in no joint group"});
  free.body_a = 501, free.body_b = 14;
  expect_refused([&] { sim.add_joint(sim.time_of(7), free); },
                 {at(93) + "7: body_b: body 501 is in no joint group, body 14 is in the joint group of body 11"});
  // Two bodies added at step 6 and joined there: a group spawned whole. Body
  // 500, added at 5, cannot join it at 6.
  Body third = other;
  third.id = 502;
  third.position += Vec3(1.0, 0.0, 0.0);
  sim.add_body(sim.time_of(6), third);
  Joint spawned = loop(s, 96, JointKind::PointToPoint, 9, 9);
  spawned.body_a = 501, spawned.body_b = 502;
  sim.add_joint(sim.time_of(6), spawned);
  free.body_a = 500, free.body_b = 502;
  expect_refused([&] { sim.add_joint(sim.time_of(6), free); },
                 {at(93) + "6: body_b: body 500 is in no joint group, body 502 is in the joint group of body 501",
                  "unless all their bodies are added at its step"});
  // Ids: a scene joint's, a removed joint's, one added by input.
  expect_refused([&] { sim.add_joint(sim.time_of(30), pin(s, 3, 12, 0)); }, {at(3) + "30: id: joint 3 is in use"});
  expect_refused([&] { sim.add_joint(sim.time_of(30), pin(s, j56, 12, 0)); },
                 {"id: joint " + std::to_string(j56) + " is in use (removed at step 20"});
  expect_refused([&] { sim.add_joint(sim.time_of(50), pin(s, kLoop, 12, 0)); }, {"id: joint 1001 is in use"});
  // Bodies: unknown, removed, not added yet, static-static, itself.
  Joint bad = pin(s, 94, 12, 0);
  bad.body_b = 9999;
  expect_refused([&] { sim.add_joint(sim.time_of(30), bad); }, {at(94) + "30: body_b: no body has id 9999"});
  bad = pin(s, 94, 22, 0);
  expect_refused([&] { sim.add_joint(sim.time_of(12), bad); },
                 {at(94) + "12: body_a: body 22 is not in the scene then", "removed at step 10"});
  bad.body_a = 501;
  expect_refused([&] { sim.add_joint(sim.time_of(3), bad); }, {"body_a: body 501 is not in the scene then (added at step 6"});
  bad.body_a = 1, bad.body_b = 10;
  expect_refused([&] { sim.add_joint(sim.time_of(30), bad); },
                 {at(94) + "30: field 'body_b': both bodies (1, 10) are static"});
  bad.body_a = 12, bad.body_b = 12;
  expect_refused([&] { sim.add_joint(sim.time_of(30), bad); }, {"field 'body_b': joins body 12 to itself"});
  // Values: a hinge's limit upside down, a frame not finite.
  Joint hinge = loop(s, 95, JointKind::Hinge, 12, 14);
  hinge.limited = true, hinge.lower = 1.0, hinge.upper = -1.0;
  expect_refused([&] { sim.add_joint(sim.time_of(30), hinge); }, {at(95) + "30: field 'limit': lower"});
  hinge = loop(s, 95, JointKind::Hinge, 12, 14);
  hinge.frame_a.position.x() = std::nan("");
  expect_refused([&] { sim.add_joint(sim.time_of(30), hinge); }, {"field 'frame_a.position'"});
  // The loop added at 40 needs chain 1 whole until then.
  expect_refused([&] { sim.remove_joint(sim.time_of(30), j1213); },
                 {"remove joint " + std::to_string(j1213) + " at step 30: joint: it would split the joint group of "
                  "bodies 11 and 14 before joint 1001, added at step 40, closes a loop in it"});
  expect_refused([&] { sim.remove_body(sim.time_of(35), 13); }, {"remove body 13 at step 35: it would split"});
  expect_refused([&] { sim.remove_body(sim.time_of(35), 14); }, {"remove body 14 at step 35", "later step 40"});
  expect_refused([&] { sim.remove_joint(sim.time_of(35), kLoop); }, {"joint 1001 is added at step 40 only"});
  // Link 7 keeps the loop 4-7 (added at 19) from step 19 on; a removal of 4-5 at 10 would split it.
  expect_refused([&] { sim.remove_joint(sim.time_of(10), joint_between(s, 4, 5)); }, {"before joint 92"});
  sim.remove_joint(sim.time_of(40), j1213);  // at the loop's step, after it: accepted
  sim.remove_body(sim.time_of(45), 13);      // after it: accepted (the loop holds 11-12 and 14 together)
  sim.remove_joint(sim.time_of(50), kLoop);  // an added joint removed

  const std::vector<UserInput> log = sim.input_log();
  ASSERT_EQ(log.size(), 13u);
  EXPECT_TRUE(sim.advance_to(sim.time_of(60)));
  Simulation clean(s, SimulationConfig{.territories = 1});
  for (const UserInput& in : log) clean.give(in);
  EXPECT_TRUE(clean.advance_to(clean.time_of(60)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(clean.state_hash()));
  // Scene joints less 5-6, 21-22 and 22-23 (body 22), 12-13, 13-14 (body 13); the pins 1000 and 1002, loop 92
  // and the spawned pair's 96.
  EXPECT_EQ(sim.snapshot().state.joints.size(), s.joints.size() - 5 + 4);
  sim.stop();
  clean.stop();
}

// ragdolls 4 with ragdoll 3 (bodies 34..44, joints 30..39) spawned again
// three times above the pile while the worlds run, each 11 add_body and 10
// add_joint at one step: queued for step 20, at the frame on screen at 40,
// given at frame 50 for step 70. Ids + 100, + 200, + 300.
std::vector<test::PlannedInput> spawn_plan() {
  const Scene& s = scene_of(joint_scenes()[2]);
  struct Spawn {
    std::int64_t step;
    bool at_frame;
    int given_at;
    double up;
  };
  const Spawn spawns[] = {{20, false, -1, 2.5}, {40, true, -1, 5.0}, {70, false, 50, 7.5}};
  std::vector<test::PlannedInput> out;
  for (std::size_t k = 0; k < 3; ++k) {
    const Spawn& at = spawns[k];
    const BodyId offset = static_cast<BodyId>(100 * (k + 1));
    for (BodyId id = 34; id <= 44; ++id) {
      UserInput in;
      in.kind = UserInput::Kind::AddBody;
      in.step = at.step;
      in.body = body_of(s, id);
      in.body.id += offset;
      in.body.position.y() += at.up;
      out.push_back({in, at.at_frame, at.given_at});
    }
    for (const Joint& j : s.joints) {
      if (j.body_a < 34 || j.body_a > 44) continue;
      Joint copy = j;
      copy.id += offset, copy.body_a += offset, copy.body_b += offset;
      out.push_back({add_joint(at.step, copy), at.at_frame, at.given_at});
    }
  }
  return out;
}

class JointSpawns : public ::testing::TestWithParam<std::tuple<int, int>> {};

// Each spawned ragdoll is taken whole by the world owning its pelvis's
// (anchor's) home cell, wherever its other bodies' cells are: the grid's
// border x = 0 runs through the pile, between a ragdoll's arms.
TEST_P(JointSpawns, EveryFrameWithRagdollsSpawnedEqualsOneTerritory) {
  const auto [territories, anticipation] = GetParam();
  const Scene& s = scene_of(joint_scenes()[2]);
  static const test::QueuedRun ref = test::queued_run(s, spawn_plan(), kSteps);
  test::Progress progress;
  SimulationConfig config{.territories = territories, .buffer_capacity = 16, .past_inputs = true};
  if (territories > 1) config.partition = territories == 2 ? "grid:2x1x1" : "grid:2x2x1";
  config.runtime.anticipation = anticipation;
  config.after_step = progress.hook();
  detail::edit_testing_hooks(config).verify_replay = true;
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  const test::RenderedRun run = test::run_game_loop(sim, reader, progress, spawn_plan(), ref.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  const std::size_t joints = sim.snapshot().state.joints.size();
  sim.stop();
  // The ragdoll spawned at 20 in the frame of step 21 (the inputs queued):
  // one owner, bodies on both sides of x = 0.
  Simulation probe(s, SimulationConfig{.territories = territories, .partition = config.partition});
  for (const test::PlannedInput& i : spawn_plan()) probe.give(i.input);
  SceneReader probe_reader = probe.add_reader();
  EXPECT_TRUE(probe.advance_to(probe.time_of(21)));
  std::set<WorldId> owners;
  bool left = false, right = false;
  for (BodyId id = 134; id <= 144; ++id) {
    const std::optional<BodyAt> at = probe_reader.body_at(probe.time_of(21), id);
    ASSERT_TRUE(at.has_value()) << id;
    owners.insert(at->owner);
    (at->pose.position[0] < 0 ? left : right) = true;
  }
  probe.stop();
  EXPECT_EQ(owners.size(), 1u);
  EXPECT_TRUE(left && right);
  std::printf("[ ragdolls 4 %s, K %d, anticipation %d, 3 ragdolls spawned ] %llu rollbacks; %zu joints; hash %s, one "
              "territory %s\n",
              kPrecisionName, territories, anticipation, static_cast<unsigned long long>(sim.rollbacks()), joints,
              hash_hex(hash).c_str(), hash_hex(ref.hash).c_str());
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_GE(sim.rollbacks(), 1u);
  EXPECT_EQ(joints, s.joints.size() + 30);
  EXPECT_EQ(run.bodies.at(kSteps), s.dynamic_count() + 33);
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
}

INSTANTIATE_TEST_SUITE_P(Simulation, JointSpawns,
                         ::testing::Combine(::testing::Values(1, 2, 4), ::testing::Values(0, 8)),
                         [](const auto& info) {
                           return "K" + std::to_string(std::get<0>(info.param)) + "_anticipation" +
                                  std::to_string(std::get<1>(info.param));
                         });

TEST(JointAddScenes, InputFileRefusesABadJoint) {
  const auto refused = test::expect_input_file_refused;
  refused(R"({"type": "add_joint", "step": 3})", {"add_joint at step 3", "'joint'", "missing"});
  refused(R"({"type": "add_joint", "step": 3, "joint": 4})", {"add_joint at step 3): joint", "must be an object"});
  refused(R"({"type": "add_joint", "step": 3, "joint": {"id": 7, "type": "hinge", "body_a": 1, "body_b": 2,
          "limit": [1, -1]}})",
          {"add_joint at step 3): joint (id 7)", "field 'limit'", "is above upper"});
  refused(R"({"type": "add_joint", "step": 3, "joint": {"id": 7, "type": "rope", "body_a": 1, "body_b": 2}})",
          {"joint (id 7)", "unknown joint type 'rope'"});
  refused(R"({"type": "add_joint", "step": 3, "joint": {"id": 7, "type": "hinge", "body_a": 1, "body_b": 1}})",
          {"field 'body_b'", "to itself"});
  const std::vector<UserInput> ok = parse_inputs_json(
      R"({"format": "soda-inputs", "version": 1, "inputs": [{"type": "add_joint", "step": 3, "joint": {"id": 7,
          "type": "hinge", "body_a": 1, "body_b": 2, "frame_a": {"position": [0.5, 0, 0]}, "limit": [-1, 1]}}]})",
      "ok.json");
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok[0].kind, UserInput::Kind::AddJoint);
  EXPECT_EQ(ok[0].joint, 7u);
  EXPECT_EQ(ok[0].added_joint.kind, JointKind::Hinge);
  EXPECT_TRUE(ok[0].added_joint.limited);
  EXPECT_EQ(ok[0].added_joint.frame_a.position, Vec3(0.5, 0, 0));
}


// A joint added between bodies in contact, at the frame on screen: its
// bodies stop colliding from that step on, so their contact ends there —
// in the run that re-runs the step from the state kept at its boundary
// (which holds the contact) as in the one that never left it. Boxes resting
// on the ground on both sides of a 2x1x1 cut, two of them pinned to it at
// their bottom centre (one at the frame on screen, one queued), one hinged.
TEST(JointAddScenes, AJointBetweenTouchingBodiesEndsTheirContact) {
  Scene s;
  s.name = "resting-boxes";
  Body ground;
  ground.id = 1, ground.is_static = true, ground.shape = Shape::box(Vec3(8, 0.5, 4)), ground.position = Vec3(0, -0.5, 0);
  s.bodies.push_back(ground);
  for (int i = 0; i < 4; ++i) {
    Body b;
    b.id = static_cast<BodyId>(2 + i);
    b.shape = Shape::box(Vec3::Constant(0.5));
    b.position = Vec3(-3.0 + 2.0 * i, 0.5, 0.3 * i);
    s.bodies.push_back(b);
  }
  auto bottom = [&](BodyId id) -> Vec3 { return body_of(s, id).position - Vec3(0, 0.5, 0); };
  Joint hinge = joint_at(s, 11, JointKind::Hinge, 1, 4, bottom(4) + Vec3(0.5, 0, 0));
  const std::vector<test::PlannedInput> plan = {
      {add_joint(30, joint_at(s, 10, JointKind::PointToPoint, 2, 1, bottom(2))), true},
      {add_joint(30, hinge), true},
      {add_joint(40, joint_at(s, 12, JointKind::PointToPoint, 5, 1, bottom(5)))},
      {UserInput{.kind = UserInput::Kind::ApplyImpulse, .step = 45, .id = 4, .linear = Vec3(0, 3, 0)}, true},
  };
  const test::QueuedRun ref = test::queued_run(s, plan, kSteps);
  for (const auto& [territories, anticipation] : {std::pair{1, 0}, {2, 0}, {2, 8}}) {
    test::Progress progress;
    SimulationConfig config{.territories = territories, .partition = territories > 1 ? "grid:2x1x1" : "kmeans",
                            .buffer_capacity = 16, .past_inputs = true};
    config.runtime.anticipation = anticipation;
    config.after_step = progress.hook();
    Simulation sim(s, config);
    SceneReader reader = sim.add_reader();
    const test::RenderedRun run = test::run_game_loop(sim, reader, progress, plan, ref.frames, kSteps);
    const std::uint64_t hash = sim.state_hash();
    sim.stop();
    std::printf("[ resting boxes, K %d, anticipation %d ] %llu rollbacks; %s, one territory %s\n", territories,
                anticipation, static_cast<unsigned long long>(sim.rollbacks()), hash_hex(hash).c_str(),
                hash_hex(ref.hash).c_str());
    EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                                 << (run.bad.empty() ? "" : run.bad.front());
    EXPECT_GT(sim.rollbacks(), 0u);
    EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash)) << "K " << territories << ", anticipation " << anticipation;
  }
}

}  // namespace
}  // namespace soda
