// Joints in one world (docs/determinism.md, "Joints"): a joint is an island
// edge, an island's joints are solved in joint id order, and a snapshot
// carries them. Each test compares states bit for bit.
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "soda/worlds/stock_world.h"
#include "soda/worlds/world_snapshot.h"
#include "world_test_util.h"

namespace soda {
namespace {

Scene joint_scene(const std::string& name, int n, std::uint64_t seed = 3) {
  return make_scene(name, SceneParams{n, seed, false});
}

std::uint64_t run_hash(const Scene& scene, int steps, const std::vector<std::size_t>& order = {}) {
  CanonicalWorld w(scene, order);
  test::run(w, steps);
  return w.state_hash(true);
}

// The world position of a joint's frame on one of its bodies.
Vec3 pivot_in_world(const std::vector<BodyState>& states, BodyId id, const Vec3& local) {
  for (const BodyState& s : states)
    if (s.id == id) {
      Eigen::Matrix3d basis;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) basis(r, c) = double(s.basis[3 * r + c]);
      return Vec3(double(s.origin[0]), double(s.origin[1]), double(s.origin[2])) + basis * local;
    }
  ADD_FAILURE() << "no body " << id;
  return Vec3::Zero();
}

TEST(JointWorld, JointScenesDoNotDependOnInsertionOrder) {
  for (const char* name : {"pendulums", "chain-bridge", "ragdolls"}) {
    const Scene scene = joint_scene(name, 6);
    ASSERT_FALSE(scene.joints.empty()) << name;
    const std::uint64_t reference = run_hash(scene, 240);
    EXPECT_EQ(run_hash(scene, 240, test::reversed_order(scene.bodies.size())), reference) << name;
    EXPECT_EQ(run_hash(scene, 240, test::shuffled_order(scene.bodies.size(), 11)), reference) << name;
    // Joints listed in another order: still created and solved in id order.
    Scene reordered = scene;
    std::reverse(reordered.joints.begin(), reordered.joints.end());
    EXPECT_EQ(run_hash(reordered, 240), reference) << name;
  }
}

TEST(JointWorld, AJointIsAnIslandEdge) {
  const Scene scene = joint_scene("pendulums", 8);  // 4 chains of 8 links, no contacts while they swing
  CanonicalWorld w(scene);
  w.step();
  EXPECT_EQ(w.last_step_stats().islands, 4u);  // one island per chain
  EXPECT_EQ(w.last_step_stats().solved_joints, scene.joints.size());
  EXPECT_EQ(w.last_step_stats().contact_manifolds, 0u);  // jointed links do not collide
}

TEST(JointWorld, ChainsHoldTogether) {
  const Scene scene = joint_scene("pendulums", 16);
  CanonicalWorld w(scene);
  const BodyId last_link = 17;  // anchor 1, links 2 .. 17 of the first chain
  double least_x = 1e9;
  for (int i = 0; i < 300; ++i) {
    w.step();
    for (const BodyState& s : w.body_states())
      if (s.id == last_link) least_x = std::min(least_x, double(s.origin[0]));
  }
  EXPECT_LT(least_x, 0.0) << "the chain did not swing through x = 0";
  const std::vector<BodyState> states = w.body_states();
  double worst = 0;
  for (const Joint& j : scene.joints) {
    const Vec3 a = pivot_in_world(states, j.body_a, j.frame_a.position);
    const Vec3 b = pivot_in_world(states, j.body_b, j.frame_b.position);
    worst = std::max(worst, (a - b).norm());
  }
  EXPECT_LT(worst, 0.1) << "a link came apart";  // links are 0.5 m; 10 iterations stretch a chain by cm
  EXPECT_EQ(w.broken_joint_count(), 0u);
}

TEST(JointWorld, SnapshotRestoreStepsExactly) {
  for (const char* name : {"chain-bridge", "ragdolls"}) {
    const Scene scene = joint_scene(name, 6);
    CanonicalWorld w(scene);
    test::run(w, 90);
    const WorldSnapshot snap = w.snapshot();
    ASSERT_EQ(snap.joints.size(), scene.joints.size());
    const WorldSnapshot bytes = deserialize_snapshot(serialize(snap));
    EXPECT_TRUE(same_bits(snap, bytes));
    CanonicalWorld restored(bytes, test::shuffled_order(bytes.bodies.size(), 5));
    test::run(w, 150);
    test::run(restored, 150);
    EXPECT_EQ(restored.state_hash(true), w.state_hash(true)) << name;
  }
}

TEST(JointWorld, SnapshotsWithoutJointsKeepTheirVersion) {
  CanonicalWorld w(test::scene("falling-cubes", 20));
  test::run(w, 10);
  const std::vector<std::uint8_t> bytes = serialize(w.snapshot());
  ASSERT_GT(bytes.size(), 12u);
  EXPECT_EQ(bytes[8], 11u);  // the version after the magic: a snapshot without joints
  CanonicalWorld j(joint_scene("pendulums", 4));
  EXPECT_EQ(serialize(j.snapshot())[8], 12u);
}

TEST(JointWorld, BrokenJointsStayBrokenAcrossSnapshots) {
  Scene scene = joint_scene("pendulums", 8);
  for (Joint& j : scene.joints) j.breaking_impulse = 0.5;  // far below a swinging chain's pull
  CanonicalWorld w(scene);
  test::run(w, 60);
  ASSERT_GT(w.broken_joint_count(), 0u);
  CanonicalWorld restored(deserialize_snapshot(serialize(w.snapshot())));
  EXPECT_EQ(restored.broken_joint_count(), w.broken_joint_count());
  test::run(w, 120);
  test::run(restored, 120);
  EXPECT_EQ(restored.state_hash(true), w.state_hash(true));
  EXPECT_EQ(restored.broken_joint_count(), w.broken_joint_count());
}

TEST(JointWorld, CollideConnectedIsAFilter) {
  // Two overlapping boxes held by a fixed joint: no contact unless asked.
  Scene scene = joint_scene("pendulums", 1);
  scene.joints.clear();
  Body a = scene.bodies[2];
  Body b = a;
  b.id = 100;
  b.position.x() += 0.3;  // overlaps a by 0.2 m
  scene.bodies = {scene.bodies[0], a, b};
  Joint j;
  j.id = 1;
  j.kind = JointKind::Fixed;
  j.body_a = a.id, j.body_b = b.id;
  j.frame_a.position = Vec3(0.15, 0, 0), j.frame_b.position = Vec3(-0.15, 0, 0);
  scene.joints = {j};
  {
    CanonicalWorld w(scene);
    test::run(w, 2);
    EXPECT_EQ(w.contact_state().size(), 0u);
  }
  scene.joints[0].collide_connected = true;
  CanonicalWorld w(scene);
  test::run(w, 2);
  EXPECT_EQ(w.contact_state().size(), 1u);
}

TEST(JointWorld, ColouredSolvePoolAndParkingChangeNothing) {
  const Scene scene = joint_scene("chain-bridge", 40);
  const std::uint64_t reference = run_hash(scene, 200);
  CanonicalWorld pooled(scene);
  pooled.set_solver_pool(std::make_shared<SolverPool>(2));
  test::run(pooled, 200);
  EXPECT_EQ(pooled.state_hash(true), reference);
  CanonicalWorld parked(scene);
  parked.set_parking(true);
  test::run(parked, 200);
  EXPECT_EQ(parked.state_hash(true), reference);
}

TEST(JointWorld, RagdollsSleepWhole) {
  const Scene scene = joint_scene("ragdolls", 2);
  CanonicalWorld w(scene);
  w.set_parking(true);
  test::run(w, 900);
  // A ragdoll is one island: its 11 bodies are asleep together or awake together.
  EXPECT_EQ(w.sleeping_count() % 11, 0u);
  EXPECT_EQ(w.parked_count(), 0u);  // a jointed island is not parked (docs/skip.md)
}

TEST(JointWorld, StockWorldTakesTheSameJoints) {
  const Scene scene = joint_scene("pendulums", 8);
  StockWorld w(scene);
  test::run(w, 200);
  const std::vector<BodyState> states = w.body_states();
  for (const Joint& j : scene.joints) {
    const Vec3 a = pivot_in_world(states, j.body_a, j.frame_a.position);
    const Vec3 b = pivot_in_world(states, j.body_b, j.frame_b.position);
    EXPECT_LT((a - b).norm(), 0.1) << "joint " << j.id;
  }
}

TEST(JointWorld, AJointToAMissingBodyIsRefused) {
  Scene scene = joint_scene("pendulums", 2);
  scene.joints[0].body_b = 9999;
  EXPECT_THROW(CanonicalWorld w(scene), std::invalid_argument);
}

}  // namespace
}  // namespace soda
