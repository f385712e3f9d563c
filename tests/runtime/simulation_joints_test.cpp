// A Simulation runs scenes with joints (docs/embedding.md, "Joints"): the
// registry's pendulums, chain-bridge and ragdolls under the game loop — a
// render thread reads every frame while the worlds run, and gives inputs on
// jointed bodies (a velocity, an impulse, the removal of a body in the
// middle of a joint group) at the frame on screen, each a rollback, while
// others were queued ahead. Every frame the reader returns and the final
// hash equal the one-territory run with every input queued before it, for
// K = 1, 2, 4, lockstep and speculating, a thread per world and a pool of
// two. Removing a jointed body removes its joints at the same step; what is
// left of its group regroups and migrates to its new anchor's world.
// Checkpoints carry the joints with their broken flags. Label
// "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

constexpr int kSteps = 120;

struct JointScene {
  const char* name;
  int n;
  // Jointed bodies the plan names (see plan()).
  BodyId pushed_ahead, set_at_frame, removed_at_frame, pushed_at_frame, removed_ahead;
};

// pendulums 8: chain c holds links 2 + 9c .. 9 + 9c from a static anchor;
// link 5 in the middle of chain 0 goes (links 6..9 fall free, a group of
// their own anchored at 6), then link 20, the first of chain 2 (its joint to
// the static anchor goes too). chain-bridge 12: planks 3..14 hinged edge to
// edge between two pillars; plank 8 goes (the bridge falls in two: 9..14
// anchored at 9, on the other side of the scene), then plank 3. ragdolls 4:
// ragdoll r is bodies 1 + 11r .. 11 + 11r, pelvis first; the pelvis of
// ragdoll 2 goes (its legs and its upper body fall apart into three
// groups), then the spine of ragdoll 3.
const std::vector<JointScene>& joint_scenes() {
  static const std::vector<JointScene> all = {
      {"pendulums", 8, 9, 13, 5, 7, 20},
      {"chain-bridge", 12, 6, 10, 8, 11, 3},
      {"ragdolls", 4, 3, 13, 23, 26, 35},
  };
  return all;
}

const Scene& scene_of(const JointScene& j) {
  static std::map<std::string, Scene> made;
  auto it = made.find(j.name);
  if (it == made.end()) it = made.emplace(j.name, test::scene(j.name, j.n)).first;
  return it->second;
}

UserInput on(UserInput::Kind kind, std::int64_t step, BodyId id, Vec3 v = Vec3::Zero()) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  in.linear = v;
  return in;
}

// Given by the render thread at the frame on screen (a rollback) or ahead.
std::vector<test::PlannedInput> plan(const JointScene& j) {
  using K = UserInput::Kind;
  return {
      {on(K::ApplyImpulse, 10, j.pushed_ahead, Vec3(0, 4, 3))},
      {on(K::SetVelocity, 25, j.set_at_frame, Vec3(1, 2, 0)), true},
      {on(K::RemoveBody, 40, j.removed_at_frame), true},
      {on(K::ApplyImpulse, 55, j.pushed_at_frame, Vec3(-2, 3, 1)), true},
      {on(K::RemoveBody, 70, j.removed_ahead), false, 50},
  };
}

// The one-territory run with every input queued before it.
const test::QueuedRun& reference(const JointScene& j) {
  static std::map<std::string, test::QueuedRun> made;
  auto it = made.find(j.name);
  if (it == made.end()) it = made.emplace(j.name, test::queued_run(scene_of(j), plan(j), kSteps)).first;
  return it->second;
}

// scene, territories, anticipation, threads (0: one per world, 2: a pool of two)
class SimulationJoints : public ::testing::TestWithParam<std::tuple<int, int, int, int>> {};

TEST_P(SimulationJoints, EveryFrameWithInputsOnJointedBodiesEqualsOneTerritory) {
  const auto [scene_index, territories, anticipation, threads] = GetParam();
  const JointScene& j = joint_scenes()[static_cast<std::size_t>(scene_index)];
  const Scene& s = scene_of(j);
  ASSERT_FALSE(s.joints.empty());
  const test::QueuedRun& ref = reference(j);

  test::Progress progress;
  SimulationConfig config{.territories = territories, .threads = threads, .buffer_capacity = 16, .past_inputs = true};
  config.runtime.anticipation = anticipation;
  config.after_step = progress.hook();
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  const test::RenderedRun run = test::run_game_loop(sim, reader, progress, plan(j), ref.frames, kSteps);
  const std::vector<std::size_t>& bodies = run.bodies;
  const std::uint64_t hash = sim.state_hash();
  const std::size_t dynamic = s.dynamic_count();
  sim.stop();
  std::printf("[ %s %d %s, K %d, anticipation %d, threads %d ] %llu rollbacks for %zu inputs at the frame on "
              "screen; bodies at frames 0/41/71/%d: %zu/%zu/%zu/%zu; hash %s, one territory %s\n",
              j.name, j.n, kPrecisionName, territories, anticipation, threads,
              static_cast<unsigned long long>(sim.rollbacks()), run.at_frame, kSteps, bodies.at(0), bodies.at(41),
              bodies.at(71), bodies.at(kSteps), hash_hex(hash).c_str(), hash_hex(ref.hash).c_str());
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(sim.rollbacks(), run.at_frame);
  EXPECT_EQ(bodies.at(0), dynamic);
  EXPECT_EQ(bodies.at(41), dynamic - 1);
  EXPECT_EQ(bodies.at(71), dynamic - 2);
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
}

std::vector<std::tuple<int, int, int, int>> cases() {
  std::vector<std::tuple<int, int, int, int>> out;
  for (int scene = 0; scene < 3; ++scene)
    for (const auto& [k, threads] : {std::pair{1, 0}, std::pair{2, 0}, std::pair{4, 0}, std::pair{4, 2}})
      for (int anticipation : {0, 8}) out.emplace_back(scene, k, anticipation, threads);
  return out;
}

INSTANTIATE_TEST_SUITE_P(Simulation, SimulationJoints, ::testing::ValuesIn(cases()), [](const auto& info) {
  std::string name = std::string(joint_scenes()[static_cast<std::size_t>(std::get<0>(info.param))].name) + "_K" +
                     std::to_string(std::get<1>(info.param)) + "_anticipation" +
                     std::to_string(std::get<2>(info.param)) + "_threads" + std::to_string(std::get<3>(info.param));
  for (char& ch : name)
    if (ch == '-') ch = '_';
  return name;
});

// Without inputs, a Simulation on K territories is the one world's run.
TEST(SimulationJointScenes, WithoutInputsEqualTheOneWorld) {
  for (const JointScene& j : joint_scenes()) {
    CanonicalWorld one(scene_of(j));
    for (int i = 0; i < kSteps; ++i) one.step();
    for (int k : {1, 4}) {
      SimulationConfig config{.territories = k};
      config.runtime.anticipation = k > 1 ? 8 : 0;
      Simulation sim(scene_of(j), config);
      EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
      EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(one.state_hash())) << j.name << " K=" << k;
      sim.stop();
    }
    std::printf("[ %s %d %s ] one world %s after %d steps\n", j.name, j.n, kPrecisionName,
                hash_hex(one.state_hash()).c_str(), kSteps);
  }
}

// The same inputs, all given before the run, in a PartitionedWorld that
// checks ownership every step under SyncTest (every step restored from its
// snapshot and re-run): the Simulation's one-territory hash.
TEST(SimulationJointScenes, InputsUnderSyncTestAndValidationGiveTheSameHash) {
  for (const JointScene& j : joint_scenes()) {
    if (test::kThreadSanitizer && std::string(j.name) != "ragdolls") continue;  // one scene under TSan
    std::vector<UserInput> inputs;
    for (const test::PlannedInput& i : plan(j)) inputs.push_back(i.input);
    for (std::size_t i = 0; i < inputs.size(); ++i) inputs[i].sequence = i;
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

// Removing plank 8 of the bridge cuts it in two: planks 9..14 form a group
// anchored at plank 9, whose home cell is in the other territory of a 2x1x1
// cut. That world owns it from the end of the next step on; plank 3's
// world keeps planks 3..7. The frames tell who owned each body; the hash is
// one territory's.
TEST(SimulationJointScenes, WhatIsLeftOfAGroupMigratesToItsNewAnchor) {
  const JointScene& j = joint_scenes()[1];
  const Scene& s = scene_of(j);
  Simulation sim(s, SimulationConfig{.territories = 2, .partition = "grid:2x1x1"});
  sim.remove_body(sim.time_of(40), 8);
  SceneReader reader = sim.add_reader();
  EXPECT_TRUE(sim.advance_to(sim.time_of(45)));
  auto owner = [&](int step, BodyId id) {
    const std::optional<BodyAt> at = reader.body_at(sim.time_of(step), id);
    return at ? at->owner : kNoWorld;
  };
  const WorldId left = owner(40, 3);
  EXPECT_EQ(owner(40, 9), left);  // the whole bridge is plank 3's group
  EXPECT_EQ(owner(40, 14), left);
  // Removed at boundary 40: the pieces regroup, and during step 41 the
  // right-hand one migrates to plank 9's world.
  const WorldId right = owner(41, 9);
  std::printf("[ chain-bridge 12 %s, grid:2x1x1 ] planks 3..14 in world %d at step 40; at 41 planks 3..7 in "
              "world %d, 9..14 in world %d\n",
              kPrecisionName, left, owner(41, 3), right);
  EXPECT_NE(right, left);
  EXPECT_NE(right, kNoWorld);
  EXPECT_EQ(owner(41, 14), right);
  EXPECT_EQ(owner(41, 7), left);
  EXPECT_FALSE(reader.body_at(sim.time_of(41), 8).has_value());
  Simulation one(s, SimulationConfig{.territories = 1});
  one.remove_body(one.time_of(40), 8);
  EXPECT_TRUE(one.advance_to(one.time_of(45)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(one.state_hash()));
  one.stop();
  sim.stop();
}

// Checkpoints carry the joints with their broken flags: pendulums whose
// joints break, a jointed body removed at step 30, another removal queued
// for step 150; saved at step 120 on 2 territories, restored from the file
// on 1 and on 4 speculating, and from the snapshot in this process: each
// ends at step 200 on the uninterrupted hash. Version 7 cannot hold joints.
TEST(SimulationJointScenes, CheckpointsCarryJointsAndTheirBrokenFlags) {
  Scene s = test::scene("pendulums", 8);
  for (Joint& joint : s.joints) joint.breaking_impulse = 4.0;
  auto inputs = [](Simulation& sim) {
    sim.remove_body(sim.time_of(30), 14);
    sim.remove_body(sim.time_of(150), 23);
  };
  Simulation whole(s, SimulationConfig{.territories = 1});
  inputs(whole);
  EXPECT_TRUE(whole.advance_to(whole.time_of(200)));
  const std::string expected = hash_hex(whole.state_hash());
  whole.stop();

  Simulation sim(s, SimulationConfig{.territories = 2});
  inputs(sim);
  EXPECT_TRUE(sim.advance_to(sim.time_of(120)));
  const SimulationSnapshot snap = sim.snapshot();
  std::size_t broken = 0;
  for (const JointSnapshot& js : snap.state.joints) broken += js.broken;
  EXPECT_EQ(snap.state.joints.size(), s.joints.size() - 2);  // link 14's two joints went with it
  EXPECT_GT(broken, 0u);
  EXPECT_EQ(snap.inputs.size(), 1u);
  const std::string path = (std::filesystem::temp_directory_path() / "soda-joints.ckpt").string();
  EXPECT_EQ(sim.save(path), 120);
  sim.stop();
  const SimulationSnapshot back = read_checkpoint(path);
  ASSERT_EQ(back.state.joints.size(), snap.state.joints.size());
  for (std::size_t i = 0; i < back.state.joints.size(); ++i) {
    EXPECT_EQ(back.state.joints[i].description.id, snap.state.joints[i].description.id);
    EXPECT_EQ(back.state.joints[i].broken, snap.state.joints[i].broken);
  }
  EXPECT_EQ(checkpoint_header(encode_checkpoint(back)).version, kCheckpointVersion);
  try {
    encode_checkpoint(back, 7);
    ADD_FAILURE() << "version 7 took joints";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 7 cannot hold joint"), std::string::npos) << e.what();
  }
  for (int k : {1, 4}) {
    SimulationConfig config{.territories = k};
    config.runtime.anticipation = k > 1 ? 8 : 0;
    Simulation resumed = Simulation::resume(path, config);
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(200)));
    std::printf("[ pendulums 8 breaking %s ] %zu of %zu joints broken at step 120; resumed on %d: %s, "
                "uninterrupted %s\n",
                kPrecisionName, broken, snap.state.joints.size(), k, hash_hex(resumed.state_hash()).c_str(),
                expected.c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), expected) << "K=" << k;
    resumed.stop();
  }
  std::filesystem::remove(path);
  Simulation restored(snap, SimulationConfig{.territories = 4});
  EXPECT_TRUE(restored.advance_to(restored.time_of(200)));
  EXPECT_EQ(hash_hex(restored.state_hash()), expected);
  restored.stop();
}

// Contact events and queries see ragdolls as one world does: the contact
// stream of 4 speculating territories on one thread (the worlds run
// round-robin, some ahead, rolling back) with the plan's inputs, and a
// ray cast down the pile at every 10th step, equal one territory's.
struct Observed {
  std::vector<ContactStep> contacts;
  std::vector<std::vector<std::pair<BodyId, double>>> rays;
};

Observed observe(int territories) {
  const JointScene& j = joint_scenes()[2];
  SimulationConfig config{.territories = territories, .threads = 1, .contact_events = true};
  config.runtime.anticipation = territories > 1 ? 8 : 0;
  Simulation sim(scene_of(j), config);
  for (const test::PlannedInput& i : plan(j)) sim.give(i.input);
  Observed out;
  std::thread reader([&, r = sim.add_contact_reader(), q = sim.add_query()]() mutable {
    for (int t = 0; t <= kSteps; ++t) {
      std::optional<ContactStep> st = r.read_step(t);
      if (!st) break;
      out.contacts.push_back(std::move(*st));
      if (t % 10 != 0) continue;
      std::vector<std::pair<BodyId, double>> hits;
      for (double x : {-0.3, 0.0, 0.2})
        if (auto all = q.ray_cast_all(sim.time_of(t), Vec3(x, 10, 0.1), Vec3(x, -1, 0.1)))
          for (const QueryHit& h : all->items) hits.emplace_back(h.id, h.fraction);
      out.rays.push_back(std::move(hits));
    }
  });
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  reader.join();
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(reference(j).hash));
  sim.stop();
  return out;
}

TEST(SimulationJointScenes, ContactEventsAndQueriesAreTheOneTerritoryStream) {
  const Observed one = observe(1);
  const Observed four = observe(4);
  std::size_t events = 0, hits = 0;
  for (const ContactStep& st : one.contacts) events += st.events.size();
  for (const auto& r : one.rays) hits += r.size();
  std::printf("[ ragdolls 4 %s ] %zu contact events, %zu ray hits; K 4 speculating on one thread: stream %016llx, "
              "one territory %016llx\n",
              kPrecisionName, events, hits, static_cast<unsigned long long>(contact_stream_hash(four.contacts)),
              static_cast<unsigned long long>(contact_stream_hash(one.contacts)));
  ASSERT_EQ(one.contacts.size(), static_cast<std::size_t>(kSteps + 1));
  EXPECT_GT(events, 0u);
  EXPECT_GT(hits, 0u);
  EXPECT_EQ(contact_stream_hash(four.contacts), contact_stream_hash(one.contacts));
  EXPECT_EQ(four.rays, one.rays);
}

}  // namespace
}  // namespace soda
