// Joints keep decomposition invariance (docs/partitioned-step.md, "Joints"):
// the joint scenes of the registry (pendulums swinging through borders, a
// chain bridge with boxes dropped on it, ragdolls falling into a pile) and
// pendulums whose joints break end with the one-world hash for K = 1, 2, 4,
// 8 territories, speculating (anticipation 8), under SyncTest and with
// parking on and off, with cells ceded (churn) under the fuzzer on every
// schedule; hinge motors turning arms across a border do too. One
// territory world gives the canonical world's hash;
// a joint group has one owner, its joints travel in the fragments of
// border islands and with migrants, and break where their island is solved.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>

#include "driver/testing_hooks.h"
#include "runtime/partitioned_test_util.h"
#include "soda/runtime/balance_log.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

struct JointScene {
  const char* label;
  const char* name;
  int n;
  int steps;
  double breaking_impulse;  // 0: the scene's own
  bool contacts;            // bodies touch across borders: from K = 4 on, border islands hold joints
};

const std::vector<JointScene>& joint_scenes() {
  static const std::vector<JointScene> all = {
      {"pendulums", "pendulums", 8, 240, 0, false},
      {"pendulums-breaking", "pendulums", 8, 240, 4.0, false},
      {"chain-bridge", "chain-bridge", 12, 240, 0, true},
      {"ragdolls", "ragdolls", 4, 240, 0, true},
      {"chain-bridge-breaking", "chain-bridge", 12, 240, 3.0, true},
      {"ragdolls-breaking", "ragdolls", 4, 240, 2.0, true},
  };
  return all;
}

const Scene& scene_of(const JointScene& j) {
  static std::map<std::string, Scene> made;
  auto it = made.find(j.label);
  if (it != made.end()) return it->second;
  Scene s = test::scene(j.name, j.n);
  if (j.breaking_impulse > 0)
    for (Joint& joint : s.joints) joint.breaking_impulse = j.breaking_impulse;
  return made.emplace(j.label, std::move(s)).first->second;
}

struct Reference {
  std::uint64_t hash = 0;
  std::size_t broken = 0;
};

const Reference& reference(const JointScene& j) {
  static std::map<std::string, Reference> made;
  auto it = made.find(j.label);
  if (it != made.end()) return it->second;
  CanonicalWorld w(scene_of(j));
  for (int i = 0; i < j.steps; ++i) w.step();
  return made.emplace(j.label, Reference{w.state_hash(), w.broken_joint_count()}).first->second;
}

struct JointCase {
  JointScene scene;
  test::MatrixCase matrix;
};

class JointDecomposition : public ::testing::TestWithParam<JointCase> {};

TEST_P(JointDecomposition, EqualsTheOneWorldHash) {
  const JointCase& c = GetParam();
  const Scene& s = scene_of(c.scene);
  ASSERT_FALSE(s.joints.empty());
  const Reference& ref = reference(c.scene);
  const test::MatrixRun run = test::expect_one_world_hash(s, c.scene.label, c.matrix, c.scene.steps, ref.hash);
  const WorldMetrics& t = run.total;
  std::printf("[ %s, K %d ] joints in merged islands %llu (in place %llu), broken in one world %zu\n",
              c.scene.label, c.matrix.territories, static_cast<unsigned long long>(t.merged_island_joints),
              static_cast<unsigned long long>(t.merged_island_joints_in_place), ref.broken);
  if (c.matrix.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);  // a chain's links reach other territories
    if (c.scene.contacts && c.matrix.territories >= 4) EXPECT_GT(t.merged_island_joints, 0u);
  }
  if (c.matrix.anticipation > 0 && c.matrix.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.matrix.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
  if (c.scene.breaking_impulse > 0) EXPECT_GT(ref.broken, 0u);  // the breaking case breaks joints
}

std::vector<JointCase> cases() {
  const std::vector<test::MatrixCase> matrix = {
      {1, 0, 0, false}, {1, 0, 0, true},  {2, 0, 0, false}, {4, 0, 0, true},  {8, 0, 0, false},
      {8, 0, 0, true},  {4, 8, 0, false}, {8, 8, 0, true},  {4, 0, 2, false}, {2, 0, 2, true},
  };
  std::vector<JointCase> out;
  for (const JointScene& j : joint_scenes())
    for (const test::MatrixCase& m : matrix) out.push_back(JointCase{j, m});
  return out;
}

INSTANTIATE_TEST_SUITE_P(Partitioned, JointDecomposition, ::testing::ValuesIn(cases()), [](const auto& info) {
  std::string name = std::string(info.param.scene.label) + "_" + test::matrix_case_name(info.param.matrix);
  for (char& ch : name)
    if (ch == '-') ch = '_';
  return name;
});

// The whole scene's snapshot of a partitioned run holds every joint once,
// with the one world's broken flags.
// Cells ceded every 10 steps (churn) while speculating, with the fuzzer's
// random pauses in every stage and message, on each schedule: a joint group
// changes owner whole when its anchor's cell does, joints breaking on the
// way in one of the scenes.
TEST(JointDecomposition, ChurnFuzzedOnEverySchedule) {
  for (const char* label : {"chain-bridge", "ragdolls-breaking"}) {
    const auto j = std::find_if(joint_scenes().begin(), joint_scenes().end(),
                                [&](const JointScene& x) { return std::string(x.label) == label; });
    ASSERT_NE(j, joint_scenes().end());
    const Scene& s = scene_of(*j);
    const std::string ref = hash_hex(reference(*j).hash);
    std::uint64_t seed = 3;
    for (Schedule schedule : {Schedule::Sequential, Schedule::Pool, Schedule::ThreadPerWorld}) {
      PartitionedOptions o;
      o.schedule = schedule;
      o.threads = schedule == Schedule::Pool ? 2 : 0;
      o.runtime.anticipation = 8;
      o.runtime.balance.policy = "churn";
      o.runtime.balance.period = 10;
      o.runtime.balance.seed = seed;
      detail::edit_testing_hooks(o).fuzz_seed = seed++;
      PartitionedWorld w(s, make_partition("kmeans", s, 4, GridOptions{}), o);
      w.step(j->steps);
      const BalanceTotals t = balance_totals(w.balance_log());
      std::printf("[ %s %s, K 4, churn, fuzz %llu, schedule %d, anticipation 8 ] %lld bodies moved; %s, one world %s\n",
                  label, kPrecisionName, static_cast<unsigned long long>(seed - 1), static_cast<int>(schedule),
                  static_cast<long long>(t.bodies_moved), hash_hex(w.state_hash()).c_str(), ref.c_str());
      EXPECT_GT(t.bodies_moved, 0) << label;
      EXPECT_EQ(hash_hex(w.state_hash()), ref) << label << " schedule " << static_cast<int>(schedule);
    }
  }
}

TEST(JointDecomposition, SnapshotsHoldEveryJointOnce) {
  const JointScene& j = joint_scenes()[1];  // pendulums-breaking
  const Scene& s = scene_of(j);
  CanonicalWorld one(s);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedWorld four(s, map, PartitionedOptions{});
  for (int i = 0; i < j.steps; ++i) one.step();
  four.step(j.steps);
  const WorldSnapshot a = one.snapshot();
  const WorldSnapshot b = four.snapshot();
  ASSERT_EQ(a.joints.size(), s.joints.size());
  ASSERT_EQ(b.joints.size(), a.joints.size());
  std::size_t broken = 0;
  for (std::size_t i = 0; i < a.joints.size(); ++i) {
    EXPECT_EQ(b.joints[i].description.id, a.joints[i].description.id);
    EXPECT_EQ(b.joints[i].broken, a.joints[i].broken) << "joint " << a.joints[i].description.id;
    broken += a.joints[i].broken;
  }
  EXPECT_GT(broken, 0u);
  EXPECT_EQ(hash_hex(four.state_hash()), hash_hex(one.state_hash()));
}

// Hinge motors across a border: motor-hinge on grid:2x1x1, whose border
// x = 0 runs through both hinges. The free arm, turned by its motor, crosses
// it every half turn (its owner changes), the limited arm is lifted onto it
// and held against its limit there. Lockstep, speculating and under SyncTest:
// the one world's hash.
TEST(JointDecomposition, MotorsTurnArmsAcrossABorder) {
  const Scene s = test::scene("motor-hinge", 0);
  constexpr int kSteps = 300;  // 5 s: the free arm turns 10 rad
  CanonicalWorld one(s);
  for (int i = 0; i < kSteps; ++i) one.step();
  const TerritoryMap map = make_partition("grid:2x1x1", s, 2, GridOptions{});
  for (const auto& [anticipation, sync_test] : {std::pair{0, 0}, std::pair{8, 0}, std::pair{0, 2}}) {
    PartitionedOptions o;
    o.runtime.anticipation = anticipation;
    o.runtime.validate = true;
    o.sync_test = sync_test;
    PartitionedWorld w(s, map, o);
    w.step(kSteps);
    const WorldMetrics t = test::total(w.metrics());
    std::printf("[ motor-hinge, grid:2x1x1, anticipation %d, sync-test %d ] %s; %s, one world %s\n", anticipation,
                sync_test, test::summary(t).c_str(), hash_hex(w.state_hash()).c_str(),
                hash_hex(one.state_hash()).c_str());
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(one.state_hash()));
    EXPECT_GT(t.migrations_out, 0u);  // the free arm changes owner as it turns
  }
}

}  // namespace
}  // namespace soda
