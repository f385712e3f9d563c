// Substeps per island (worlds/src/island_substeps.h, docs/stress.md
// "Dense-pile-1000"): islands of boxes whose touching bodies move fast
// against their size are solved in substeps inside the solve stage. The
// choice reads only the island's contents, so cube-pile (whose landing
// heap triggers it, as a local island and as a merged border island) keeps
// the one-world hash with K = 1, 2, 4 territories, anticipation 8 and under
// SyncTest, and the substeps really ran (the metrics' counter). Islands of
// tall or heavy-on-light joint chains are substepped too: the rule reads the
// island's joints (the profile below), and pendulums and chain-bridge keep
// the one-world hash with it. Label "concurrency".
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <vector>

#include "island_solver_settings.h"  // worlds/src: profile_island, island_substeps
#include "runtime/partitioned_test_util.h"

namespace soda {
namespace {

constexpr int kBodies = 150;
constexpr int kSteps = 120;

// `s` run kSteps steps in one CanonicalWorld and on K = 1, 2, 4 territories
// (threads, anticipation 8): islands were substepped in each, and every K
// gives the one-world hash; `border_islands`: K > 1 solved border islands.
void expect_substepped_and_one_hash(const Scene& s, int n, bool border_islands) {
  CanonicalWorld one(s);
  std::uint64_t substepped = 0;
  for (int i = 0; i < kSteps; ++i) {
    one.step();
    substepped += one.last_step_stats().substepped_islands;
  }
  const std::uint64_t reference = one.state_hash();
  EXPECT_GT(substepped, 0u) << s.name << ": no island was solved in substeps";
  for (int k : {1, 2, 4}) {
    PartitionedOptions o;
    o.schedule = Schedule::ThreadPerWorld;
    o.runtime.anticipation = 8;
    PartitionedWorld w(s, make_partition("kmeans", s, k, GridOptions{}), o);
    w.step(kSteps);
    const WorldMetrics t = test::total(w.metrics());
    std::printf("[ %s %d %s K=%d ] %s (one world %s), %llu substepped islands (one world %llu), %llu "
                "border islands\n",
                s.name.c_str(), n, kPrecisionName, k, hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str(),
                static_cast<unsigned long long>(t.substepped_islands), static_cast<unsigned long long>(substepped),
                static_cast<unsigned long long>(t.islands_solved));
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << s.name << " K=" << k;
    EXPECT_GT(t.substepped_islands, 0u) << s.name << " K=" << k;
    if (border_islands && k > 1) {
      EXPECT_GT(t.islands_solved, 0u) << s.name << " K=" << k << ": no border island";
    }
  }
}

TEST(IslandSubsteps, CubePileOneHashForEveryTerritoryCount) {
  expect_substepped_and_one_hash(test::scene("cube-pile", kBodies), kBodies, true);
}

TEST(IslandSubsteps, CubePileSyncTest) {
#if defined(__SANITIZE_THREAD__)  // TSan looks for races: a shorter run (28 s of CI's TSan step at 120)
  constexpr int kSyncSteps = 40;
#else
  constexpr int kSyncSteps = kSteps;
#endif
  const Scene s = test::scene("cube-pile", kBodies);
  PartitionedOptions o;
  o.sync_test = 8;
  PartitionedWorld w(s, make_partition("kmeans", s, 2, GridOptions{}), o);
  w.step(kSyncSteps);
  EXPECT_EQ(w.sync_rollbacks(), static_cast<std::uint64_t>(kSyncSteps));
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(test::reference_hash(s, kSyncSteps)));
  EXPECT_GT(test::total(w.metrics()).substepped_islands, 0u);
}

// A chain of `links` boxes of `mass` kg hanging by point-to-point joints from
// a static box, with a box of `last_mass` kg at its end; its profile and the
// substeps it gets at 1/60 s.
struct Chain {
  btBoxShape shape{btVector3(0.05f, 0.25f, 0.05f)};
  std::vector<std::unique_ptr<btRigidBody>> bodies;  // [0]: the static anchor
  std::vector<std::unique_ptr<btPoint2PointConstraint>> joints;
  Chain(int links, btScalar last_mass) {
    bodies.push_back(std::make_unique<btRigidBody>(0, nullptr, &shape));
    for (int i = 0; i < links; ++i) {
      const btScalar mass = i + 1 == links ? last_mass : 1;
      bodies.push_back(std::make_unique<btRigidBody>(mass, nullptr, &shape, btVector3(1, 1, 1)));
      joints.push_back(std::make_unique<btPoint2PointConstraint>(*bodies[bodies.size() - 2], *bodies.back(),
                                                                btVector3(0, -0.25f, 0), btVector3(0, 0.25f, 0)));
    }
  }
  IslandProfile profile() {
    std::vector<btCollisionObject*> dynamic;
    for (std::size_t i = 1; i < bodies.size(); ++i) dynamic.push_back(bodies[i].get());
    std::vector<btTypedConstraint*> js;
    for (auto& j : joints) js.push_back(j.get());
    return profile_island(dynamic.data(), static_cast<int>(dynamic.size()), nullptr, 0, js.data(),
                          static_cast<int>(js.size()));
  }
};

TEST(IslandSubsteps, JointChainProfile) {
  constexpr double kH = 1.0 / 60;
  {
    Chain c(kJointSubstepHeight, 1);
    const IslandProfile p = c.profile();
    EXPECT_EQ(p.joint_height, kJointSubstepHeight);
    EXPECT_EQ(p.joint_mass_ratio, 1.0);
    EXPECT_EQ(island_substeps(p, kH), 1);
  }
  {
    Chain c(kJointSubstepHeight + 1, 1);
    EXPECT_EQ(c.profile().joint_height, kJointSubstepHeight + 1);
    EXPECT_EQ(island_substeps(c.profile(), kH), kJointSubsteps);
    c.joints[3]->setEnabled(false);  // broken: the chain below it hangs from nothing
    EXPECT_EQ(c.profile().joint_height, 3);
    EXPECT_EQ(island_substeps(c.profile(), kH), 1);
    for (auto& b : c.bodies) EXPECT_EQ(b->getCompanionId(), -1);  // scratch given back
  }
  {
    Chain c(3, 100);  // a 100 kg box under two 1 kg links
    const IslandProfile p = c.profile();
    EXPECT_EQ(p.joint_height, 3);
    EXPECT_EQ(p.joint_mass_ratio, 100.0);
    EXPECT_EQ(island_substeps(p, kH), kJointSubsteps);
  }
  {
    Chain c(3, static_cast<btScalar>(kJointSubstepMassRatio));
    EXPECT_EQ(island_substeps(c.profile(), kH), 1);
  }
}

// A box island substepped by its approach splits its iterations between the
// substeps; a joint chain substepped by the joint rule solves each substep
// with the whole iterations (the chain stretches otherwise).
TEST(IslandSubsteps, ContactSubstepsSplitTheIterationsJointSubstepsDoNot) {
  IslandProfile fast;
  fast.approach_rate = 1e3;
  ASSERT_EQ(island_substeps(fast, 1.0 / 60), kIslandSubsteps);
  EXPECT_EQ(substep_iterations(34, kIslandSubsteps, fast), 17);
  EXPECT_EQ(substep_iterations(35, kIslandSubsteps, fast), 18);  // rounded up, never below half
  EXPECT_EQ(substep_iterations(10, kIslandSubsteps, fast), kMinSubstepIterations);
  EXPECT_EQ(substep_iterations(4, kIslandSubsteps, fast), 4);  // never more than the whole step's
  EXPECT_EQ(substep_iterations(10, 1, fast), 10);
  Chain c(kJointSubstepHeight + 1, 1);
  const IslandProfile chain = c.profile();
  ASSERT_EQ(island_substeps(chain, 1.0 / 60), kJointSubsteps);
  EXPECT_EQ(substep_iterations(10, kJointSubsteps, chain), 10);
}

// Pendulums (four chains of 16 links) and chain-bridge (24 planks, with
// boxes dropped on it: border islands with joints) are substepped, and
// keep the one-world hash.
TEST(IslandSubsteps, JointChainsOneHashForEveryTerritoryCount) {
  expect_substepped_and_one_hash(test::scene("pendulums", 16), 16, false);  // no chain touches another
  expect_substepped_and_one_hash(test::scene("chain-bridge", 24), 24, true);
}

}  // namespace
}  // namespace soda
