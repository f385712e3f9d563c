// The joint cases of the stress suite (docs/stress.md, "Joint cases"): each
// passes at small sizes, and each can fail — a bound too tight, or a setup
// that is broken on purpose, gives FAIL — so the checks are not vacuous.
#include <cstdio>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "soda/bench/stress.h"
#include "soda/bench/stress_joints.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

// The quick suite's case of a group (canonical world).
StressCase joint_case(const std::string& group) {
  for (const StressCase& c : stress_suite(true))
    if (c.group == group && c.world == WorldKind::Canonical) return c;
  ADD_FAILURE() << "no case of group " << group;
  return {};
}

StressResult run_on(const Scene& scene, const StressCase& c) {
  StressResult r;
  r.c = c;
  run_joint_stress_case(r, scene, c);
  std::printf("%-6s %-20s %s\n", r.status.c_str(), c.name.c_str(), r.measured.c_str());
  return r;
}

Scene scene_of(const StressCase& c) {
  Scene scene = make_scene(c.scene, {c.n, 1, false});
  if (c.substeps > 0) scene.settings.substeps = c.substeps;
  return scene;
}

const char* const kGroups[] = {"hanging-chain", "ragdoll-pile", "heavy-chain", "motor-hinge"};

TEST(JointStress, EveryCaseHasItsStockRowAndCriterion) {
  std::set<std::string> names;
  for (const StressCase& c : stress_suite()) {
    if (!is_joint_stress_group(c.group)) continue;
    names.insert(c.name);
    EXPECT_FALSE(c.criterion.empty()) << c.name;
    EXPECT_EQ(c.world == WorldKind::Stock, c.name.ends_with("-stock")) << c.name;
  }
  for (const char* n : {"hanging-chain-100", "hanging-chain-100-stock", "ragdoll-pile-64", "ragdoll-pile-64-stock",
                        "heavy-chain-1:100", "heavy-chain-1:100-stock", "motor-hinge", "motor-hinge-stock"})
    EXPECT_TRUE(names.count(n)) << n;
  for (const char* g : kGroups) EXPECT_TRUE(is_joint_stress_group(g)) << g;
  EXPECT_FALSE(is_joint_stress_group("tower"));
}

// Small sizes (the quick suite: 2 s, 16 ragdolls), canonical world: pass.
TEST(JointStress, QuickCasesPass) {
  for (const char* g : kGroups) {
    const StressCase c = joint_case(g);
    const StressResult r = run_stress_case(c);
    std::printf("%-6s %-20s %s\n", r.status.c_str(), c.name.c_str(), r.measured.c_str());
    EXPECT_EQ(r.status, "pass") << c.name << ": " << r.measured;
    EXPECT_EQ(r.steps_run, c.steps) << c.name;
    EXPECT_LE(r.metric, r.threshold) << c.name;
    EXPECT_EQ(r.state_hash.size(), 16u) << c.name;
  }
}

// The same run judged against half of what it measured fails, with the same
// figure: every verdict rests on the measured figure, not on a constant.
TEST(JointStress, ABoundTooTightFails) {
  for (const char* g : kGroups) {
    StressCase c = joint_case(g);
    const StressResult first = run_stress_case(c);
    if (first.metric == 0) {  // a motor may hold its target to the last bit; its broken setup fails below
      EXPECT_EQ(std::string(g), "motor-hinge");
      continue;
    }
    ASSERT_GT(first.metric, 0) << c.name;
    c.bound = first.metric / 2;
    const StressResult r = run_stress_case(c);
    EXPECT_EQ(r.status, "FAIL") << c.name << ": " << r.measured;
    EXPECT_EQ(r.metric, first.metric) << c.name;
    EXPECT_EQ(r.threshold, c.bound) << c.name;
  }
}

// Broken setups fail for the reason their criterion names.
TEST(JointStress, BrokenSetupsFail) {
  {  // the chain in steps of 1/15 s: its island's substeps are then 1/60 s long, and in steps of 1/60 s
     // a 100-link chain stretches by more than a link (docs/stress.md)
    const StressCase c = joint_case("hanging-chain");
    Scene scene = scene_of(c);
    scene.settings.dt = 1.0 / 15;
    const StressResult r = run_on(scene, c);
    EXPECT_EQ(r.status, "FAIL") << r.measured;
  }
  {  // a motor without strength never reaches its target
    const StressCase c = joint_case("motor-hinge");
    Scene scene = scene_of(c);
    for (Joint& j : scene.joints) j.motor_max_impulse = 0.0;
    const StressResult r = run_on(scene, c);
    EXPECT_EQ(r.status, "FAIL") << r.measured;
    EXPECT_NE(r.measured.find("never"), std::string::npos) << r.measured;
  }
  {  // one ragdoll (bodies 1..11) thrown sideways at 40 m/s: too fast, and out of the arena
    const StressCase c = joint_case("ragdoll-pile");
    Scene scene = scene_of(c);
    for (Body& b : scene.bodies)
      if (b.id >= 1 && b.id <= 11) b.linear_velocity = Vec3(40.0, 0.0, 0.0);
    const StressResult r = run_on(scene, c);
    EXPECT_EQ(r.status, "FAIL") << r.measured;
    EXPECT_GT(r.metric, r.threshold);
  }
  {  // the heavy chain with its joints made far weaker than the load: a 10 t box
    StressCase c = joint_case("heavy-chain");
    c.n = 10000;
    const StressResult r = run_on(scene_of(c), c);
    EXPECT_EQ(r.status, "FAIL") << r.measured;
  }
}

}  // namespace
}  // namespace soda
