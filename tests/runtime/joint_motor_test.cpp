// set_joint_motor (docs/embedding.md, "Joints"; docs/inputs.md): a joint's
// motor changed by input on the registry's motor-hinge, on a row of arms
// driven by hinge and 6-DoF spring motors across territories and on the
// ragdolls' hinges in a pile across borders, under the game loop — queued before the run, given at the frame on screen (a
// rollback) and given ahead while the worlds run. Every frame the render
// thread reads and the final hash equal the one-territory run with every
// input queued before it, for K = 1, 2, 4, lockstep and anticipation 8, and
// the arms turn at the new targets. The constraint the setter leaves is the
// one a fresh description makes (a restore from the changed snapshot steps
// to the same bits); refusals name the joint and the field; a checkpoint
// with a motor input queued resumes on 1 and 4 territories. Label
// "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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
#include "soda/scene/joint_motor.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 120;
constexpr double kHeight = 3.0;

// Eight arms (boxes 1 x 0.1 x 0.1 m, 1 kg, ids 2 + 2i) held out along +x
// from static posts (ids 1 + 2i) 6 m apart along x, each turning about z
// in the vertical plane: joint i even is a hinge (motor 1.5 rad/s, max
// impulse 1 N m s), odd a spring-6dof joint with its linear axes and
// angular x, y locked, angular z free, motor on axis 5 (1.5 rad/s, max
// force 60 N m: the same impulse a step at 1/60 s). At the row's end a
// slider (joint 8): a carriage (id 18, 1 kg) on a post (id 17) at x = 48,
// free along x within [-1, 3] m of its start, its motor driving it at
// 0.5 m/s (max force 60 N).
constexpr JointId kSlider = 8;
constexpr BodyId kCarriage = 18;

Scene motor_row() {
  Scene s;
  s.name = "motor-row";
  for (int i = 0; i < 8; ++i) {
    const double x = 6.0 * i;
    Body post;
    post.id = static_cast<BodyId>(1 + 2 * i);
    post.is_static = true;
    post.shape = Shape::box(Vec3(0.05, 0.05, 0.05));
    post.position = Vec3(x - 0.1, kHeight, 0.0);
    Body arm;
    arm.id = post.id + 1;
    arm.shape = Shape::box(Vec3(0.5, 0.05, 0.05));
    arm.mass = 1.0;
    arm.position = Vec3(x + 0.5, kHeight, 0.0);
    s.bodies.push_back(post);
    s.bodies.push_back(arm);
    Joint j;
    j.id = static_cast<JointId>(i);
    j.body_a = post.id, j.body_b = arm.id;
    j.frame_a.position = Vec3(0.1, 0.0, 0.0);
    j.frame_b.position = Vec3(-0.5, 0.0, 0.0);
    if (i % 2 == 0) {
      j.kind = JointKind::Hinge;
      j.motor = true;
      j.motor_velocity = 1.5;
      j.motor_max_impulse = 1.0;
    } else {
      j.kind = JointKind::Spring6Dof;
      j.axis_lower[5] = 1.0, j.axis_upper[5] = -1.0;  // angular z free
      j.motor_velocities[5] = 1.5;
      j.motor_max_forces[5] = 60.0;
    }
    s.joints.push_back(j);
  }
  Body post;
  post.id = 17;
  post.is_static = true;
  post.shape = Shape::box(Vec3(0.05, 0.05, 0.05));
  post.position = Vec3(47.9, kHeight, 0.0);
  Body carriage;
  carriage.id = kCarriage;
  carriage.shape = Shape::box(Vec3(0.2, 0.1, 0.1));
  carriage.mass = 1.0;
  carriage.position = Vec3(48.5, kHeight, 0.0);
  s.bodies.push_back(post);
  s.bodies.push_back(carriage);
  Joint slider;
  slider.id = kSlider;
  slider.kind = JointKind::Slider;
  slider.body_a = post.id, slider.body_b = carriage.id;
  slider.frame_a.position = Vec3(0.1, 0.0, 0.0);
  slider.frame_b.position = Vec3(-0.5, 0.0, 0.0);
  slider.limited = true;
  slider.lower = -1.0, slider.upper = 3.0;
  slider.motor = true;
  slider.motor_velocity = 0.5;
  slider.motor_max_impulse = 60.0;
  s.joints.push_back(slider);
  return s;
}

UserInput motor(std::int64_t step, JointId joint, bool on, double velocity, double max_impulse, int axis = -1) {
  UserInput in;
  in.kind = UserInput::Kind::SetJointMotor;
  in.step = step;
  in.joint = joint;
  in.motor = JointMotor{on, velocity, max_impulse, axis};
  return in;
}

// The arm whose turn rate a case asserts: its body, and the target
// velocity (rad/s) it must turn at, at `step`.
struct Turn {
  BodyId arm;
  int step;
  double target;
};

struct MotorCase {
  const char* name;
  std::function<Scene()> make;
  std::vector<test::PlannedInput> plan;
  std::vector<Turn> turns;
};

// motor-hinge: joint 0 (post 1, arm 2) free at 2 rad/s, joint 1 (post 3,
// arm 4) limited, holding its arm up. Arm 2 speeds up to 5 rad/s (queued,
// step 15); arm 4's motor goes off at the frame on screen (step 30: it falls
// back to its limit), on again given ahead (frame 50, step 70); arm 2
// reverses to -3 rad/s at the frame on screen (step 90).
// motor-row: 6-DoF joint 1 to -4 rad/s (queued, step 10), hinge 2 off at
// the frame on screen (step 30), 6-DoF joint 5 off given ahead (frame 50,
// step 70), hinge 6 to 3 rad/s at the frame on screen (step 90), 6-DoF
// joint 7 to 2.5 rad/s at the frame on screen (step 100), the slider back
// at -0.8 m/s at the frame on screen (step 40).
// ragdolls 4 (ragdoll r: bodies 1 + 11r .. 11 + 11r) in one falling pile
// across the territories' borders: the first hinge (waist, elbow or knee)
// of ragdoll 0 driven (queued, step 10), of ragdoll 1 at the frame on
// screen (step 30), of ragdoll 2 given ahead (frame 50, step 70); ragdoll
// 0's off again at the frame on screen (step 90).
JointId first_hinge(const Scene& s, int ragdoll) {
  const BodyId first = static_cast<BodyId>(1 + 11 * ragdoll);
  for (const Joint& j : s.joints)
    if (j.kind == JointKind::Hinge && j.body_a >= first && j.body_a < first + 11) return j.id;
  ADD_FAILURE() << "ragdoll " << ragdoll << " has no hinge";
  return 0;
}

const std::vector<MotorCase>& motor_cases() {
  static const Scene rag = test::scene("ragdolls", 4);
  static const std::vector<MotorCase> all = {
      {"motor_hinge",
       [] { return test::scene("motor-hinge", 2); },
       {{motor(15, 0, true, 5.0, 1.0)},
        {motor(30, 1, false, 0.0, 0.0), true},
        {motor(70, 1, true, -2.0, 1.0), false, 50},
        {motor(90, 0, true, -3.0, 2.0), true}},
       {{2, 10, 2.0}, {2, 60, 5.0}, {2, kSteps, -3.0}}},
      {"motor_row",
       motor_row,
       {{motor(10, 1, true, -4.0, 60.0, 5)},
        {motor(30, 2, false, 1.5, 1.0), true},
        {motor(40, kSlider, true, -0.8, 60.0), true},
        {motor(70, 5, false, 0.0, 0.0, 5), false, 50},
        {motor(90, 6, true, 3.0, 2.0), true},
        {motor(100, 7, true, 2.5, 80.0, 5), true}},
       {{4, 8, 1.5}, {4, kSteps, -4.0}, {14, kSteps, 3.0}, {16, kSteps, 2.5}, {10, kSteps, 1.5}}},
      {"ragdolls",
       [] { return rag; },
       {{motor(10, first_hinge(rag, 0), true, 3.0, 2.0)},
        {motor(30, first_hinge(rag, 1), true, -3.0, 2.0), true},
        {motor(70, first_hinge(rag, 2), true, 4.0, 1.0), false, 50},
        {motor(90, first_hinge(rag, 0), false, 0.0, 0.0), true}},
       {}},
  };
  return all;
}

const Scene& scene_of(const MotorCase& c) {
  static std::map<std::string, Scene> made;
  auto it = made.find(c.name);
  if (it == made.end()) it = made.emplace(c.name, c.make()).first;
  return it->second;
}

const test::QueuedRun& reference(const MotorCase& c) {
  static std::map<std::string, test::QueuedRun> made;
  auto it = made.find(c.name);
  if (it == made.end()) it = made.emplace(c.name, test::queued_run(scene_of(c), c.plan, kSteps)).first;
  return it->second;
}

// The arm's angular velocity about z in frame `step` of `run`.
double turn_rate(const test::QueuedRun& run, BodyId arm, int step) {
  for (const ScenePose& p : run.frames.at(static_cast<std::size_t>(step)))
    if (p.id == arm) return double(p.angular_velocity[2]);
  ADD_FAILURE() << "no arm " << arm << " in frame " << step;
  return 0.0;
}

// The motors act: each asserted arm turns at its target then (within 2 %:
// the motor's row converges in the solver's iterations, gravity pulls
// against it). A target is about the joint's frames' z axis as Bullet
// measures it (body b's rotation relative to body a, clockwise positive):
// an arm here turns about world z at minus its target, hinge and 6-DoF
// alike.
TEST(JointMotorScenes, TheArmsTurnAtTheNewTargets) {
  for (const MotorCase& c : motor_cases()) {
    const test::QueuedRun& ref = reference(c);
    for (const Turn& t : c.turns) {
      const double w = turn_rate(ref, t.arm, t.step);
      std::printf("[ %s %s ] arm %u at step %d: %.4f rad/s about z, target %.2f\n", c.name, kPrecisionName, t.arm,
                  t.step, w, t.target);
      EXPECT_NEAR(w, -t.target, 0.02 * std::abs(t.target)) << c.name << " arm " << t.arm << " step " << t.step;
    }
  }
  // The ragdolls' hinges driven change the run.
  Simulation plain(scene_of(motor_cases()[2]), SimulationConfig{.territories = 1});
  EXPECT_TRUE(plain.advance_to(plain.time_of(kSteps)));
  EXPECT_NE(hash_hex(plain.state_hash()), hash_hex(reference(motor_cases()[2]).hash));
  plain.stop();
  // The motors turned off (hinge 2 at step 30, 6-DoF joint 5 at 70): arms
  // 6 and 12 swing under gravity, their turn rates over steps 80..120
  // spanning more than 1 rad/s (a motor on holds one rate).
  const test::QueuedRun& row = reference(motor_cases()[1]);
  for (BodyId arm : {BodyId{6}, BodyId{12}, BodyId{10}}) {
    double low = 1e9, high = -1e9;
    for (int k = 80; k <= kSteps; ++k) {
      low = std::min(low, turn_rate(row, arm, k));
      high = std::max(high, turn_rate(row, arm, k));
    }
    std::printf("[ motor_row %s ] arm %u over steps 80..120: %.4f .. %.4f rad/s\n", kPrecisionName, arm, low, high);
    if (arm == 10) {
      EXPECT_LT(high - low, 0.05) << "arm 10's motor is on";
    } else {
      EXPECT_GT(high - low, 1.0) << "arm " << arm << "'s motor is off";
    }
  }
  // The slider's carriage runs along x at its motor's target, 0.5 m/s, then
  // at the new one, -0.8 m/s (within 2 %), inside its limits.
  auto carriage = [&](int step) {
    for (const ScenePose& p : row.frames.at(static_cast<std::size_t>(step)))
      if (p.id == kCarriage) return p;
    ADD_FAILURE() << "no carriage in frame " << step;
    return ScenePose{};
  };
  for (const auto& [step, target] : {std::pair{35, 0.5}, std::pair{kSteps, -0.8}}) {
    const ScenePose p = carriage(step);
    std::printf("[ motor_row %s ] slider carriage at step %d: x %.3f m, %.4f m/s along x, target %.2f\n",
                kPrecisionName, step, double(p.position[0]), double(p.linear_velocity[0]), target);
    EXPECT_NEAR(double(p.linear_velocity[0]), target, 0.02 * std::abs(target)) << "step " << step;
    EXPECT_GT(double(p.position[0]), 48.5 - 1.0);
    EXPECT_LT(double(p.position[0]), 48.5 + 3.0);
  }
}

// case, territories, anticipation
class JointMotorInputs : public ::testing::TestWithParam<std::tuple<int, int, int>> {};

TEST_P(JointMotorInputs, EveryFrameWithMotorsSetEqualsOneTerritory) {
  const auto [index, territories, anticipation] = GetParam();
  const MotorCase& c = motor_cases()[static_cast<std::size_t>(index)];
  const Scene& s = scene_of(c);
  const test::QueuedRun& ref = reference(c);

  // A re-run's replayed islands are solved too and compared: an island
  // replayed with the joints of the run it repeats would throw.
  test::GameLoop loop(s, territories, anticipation, true);
  Simulation& sim = loop.sim;
  SceneReader& reader = loop.reader;
  const test::RenderedRun run = loop.run(c.plan, ref.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  const std::vector<JointSnapshot> joints = sim.snapshot().state.joints;
  std::set<WorldId> owners;  // of the joints' bodies b in the last frame
  for (const Joint& j : s.joints)
    if (const std::optional<BodyAt> at = reader.body_at(sim.time_of(kSteps), j.body_b)) owners.insert(at->owner);
  const std::uint64_t merged = total_metrics(sim.metrics()).merged_islands;
  sim.stop();
  std::printf("[ %s %s, K %d, anticipation %d ] %llu rollbacks; joint groups held by %zu worlds; %llu merged "
              "islands; hash %s, one territory %s\n",
              c.name, kPrecisionName, territories, anticipation, static_cast<unsigned long long>(sim.rollbacks()),
              owners.size(), static_cast<unsigned long long>(merged), hash_hex(hash).c_str(),
              hash_hex(ref.hash).c_str());
  // The row's motors are driven in every world; the ragdolls' pile spans
  // the borders of 4 (merged islands, the hinges in their owners' fragments).
  if (std::string(c.name) == "motor_row") EXPECT_EQ(owners.size(), static_cast<std::size_t>(territories));
  if (std::string(c.name) == "ragdolls" && territories == 4) EXPECT_GT(merged, 0u);
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(sim.rollbacks(), run.at_frame);
  // The snapshot holds the changed descriptions: the scene's with every
  // input's motor set, in step order.
  std::map<JointId, Joint> expected;
  for (const Joint& j : s.joints) expected[j.id] = j;
  for (const test::PlannedInput& i : c.plan) expected[i.input.joint] = with_motor(expected[i.input.joint], i.input.motor);
  ASSERT_EQ(joints.size(), s.joints.size());
  for (const JointSnapshot& j : joints) {
    const Joint& e = expected.at(j.description.id);
    EXPECT_EQ(j.description.motor, e.motor) << "joint " << e.id;
    EXPECT_EQ(j.description.motor_velocity, e.motor_velocity) << "joint " << e.id;
    EXPECT_EQ(j.description.motor_max_impulse, e.motor_max_impulse) << "joint " << e.id;
    EXPECT_EQ(j.description.motor_velocities, e.motor_velocities) << "joint " << e.id;
    EXPECT_EQ(j.description.motor_max_forces, e.motor_max_forces) << "joint " << e.id;
  }
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.hash));
}

std::vector<std::tuple<int, int, int>> cases() {
  std::vector<std::tuple<int, int, int>> out;
  for (int c = 0; c < 3; ++c)
    for (int k : {1, 2, 4})
      for (int anticipation : {0, 8}) out.emplace_back(c, k, anticipation);
  return out;
}

INSTANTIATE_TEST_SUITE_P(Simulation, JointMotorInputs, ::testing::ValuesIn(cases()), [](const auto& info) {
  return std::string(motor_cases()[static_cast<std::size_t>(std::get<0>(info.param))].name) + "_K" +
         std::to_string(std::get<1>(info.param)) + "_anticipation" + std::to_string(std::get<2>(info.param));
});

// The constraint the setter leaves steps as one made fresh from the changed
// description: the row's inputs of step 10 and 30 given to a PartitionedWorld
// (K 1 and 4) reach step 60 on the bits of a PartitionedWorld restored at
// step 30 from a snapshot whose descriptions were changed by hand (each
// constraint built anew by make_constraint) — and not on those of the run
// without the inputs. The same through the input file format under SyncTest
// and validation.
TEST(JointMotorScenes, TheSetterLeavesTheConstraintAFreshDescriptionMakes) {
  const MotorCase& c = motor_cases()[1];
  const Scene& s = scene_of(c);
  const std::vector<UserInput> inputs = {c.plan[0].input, c.plan[1].input};  // steps 10 and 30
  for (int k : {1, 4}) {
    const TerritoryMap map = make_partition("kmeans", s, k, GridOptions{});
    PartitionedOptions given;
    given.inputs = inputs;
    PartitionedWorld with_inputs(s, map, given);
    with_inputs.step(60);

    PartitionedWorld plain(s, map);
    plain.step(10);
    WorldSnapshot at10 = plain.snapshot();
    for (JointSnapshot& j : at10.joints)
      if (j.description.id == inputs[0].joint) j.description = with_motor(j.description, inputs[0].motor);
    PartitionedWorld from10(at10, map);
    from10.step(20);
    WorldSnapshot at30 = from10.snapshot();
    for (JointSnapshot& j : at30.joints)
      if (j.description.id == inputs[1].joint) j.description = with_motor(j.description, inputs[1].motor);
    PartitionedWorld restored(at30, map);
    restored.step(30);
    plain.step(50);
    std::printf("[ motor-row %s, K %d ] inputs %s, restored from changed descriptions %s, no inputs %s\n",
                kPrecisionName, k, hash_hex(with_inputs.state_hash()).c_str(), hash_hex(restored.state_hash()).c_str(),
                hash_hex(plain.state_hash()).c_str());
    EXPECT_EQ(hash_hex(with_inputs.state_hash()), hash_hex(restored.state_hash())) << "K=" << k;
    EXPECT_NE(hash_hex(with_inputs.state_hash()), hash_hex(plain.state_hash())) << "K=" << k;
  }
  for (const MotorCase& m : motor_cases()) {
    if (test::kThreadSanitizer && &m != &motor_cases()[1]) continue;  // one case under TSan: the row
    std::vector<UserInput> planned;
    for (const test::PlannedInput& i : m.plan) planned.push_back(i.input);
    const std::vector<UserInput> back = parse_inputs_json(inputs_to_json(planned), "log");
    ASSERT_EQ(back.size(), planned.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
      EXPECT_EQ(back[i].kind, UserInput::Kind::SetJointMotor);
      EXPECT_EQ(back[i].joint, planned[i].joint);
      EXPECT_EQ(back[i].motor.on, planned[i].motor.on);
      EXPECT_EQ(back[i].motor.velocity, planned[i].motor.velocity);
      EXPECT_EQ(back[i].motor.max_impulse, planned[i].motor.max_impulse);
      EXPECT_EQ(back[i].motor.axis, planned[i].motor.axis);
    }
    for (int anticipation : test::sync_test_anticipations()) {
      PartitionedOptions o;
      o.runtime.validate = true;
      o.runtime.anticipation = anticipation;
      o.sync_test = 1;
      o.inputs = back;
      PartitionedWorld w(scene_of(m), make_partition("kmeans", scene_of(m), 4, GridOptions{}), o);
      w.step(kSteps);
      std::printf("[ %s %s, K 4, sync-test 1, anticipation %d ] %s, Simulation %s\n", m.name, kPrecisionName,
                  anticipation, hash_hex(w.state_hash()).c_str(), hash_hex(reference(m).hash).c_str());
      EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference(m).hash)) << m.name << " anticipation " << anticipation;
    }
  }
}

// A motor input queued in a checkpoint: the row saved at step 40 on 2
// territories with the queued inputs of steps 10 and 30 applied and those
// of 40 (the slider's), 70 and 100 queued, resumed on 1 and on 4 speculating: the
// uninterrupted hash at step 120, the changed descriptions carried.
// Version 9 cannot hold a motor input.
TEST(JointMotorScenes, CheckpointsCarryAQueuedMotorInput) {
  const MotorCase& c = motor_cases()[1];
  const Scene& s = scene_of(c);
  auto inputs = [&](Simulation& sim) {
    for (const test::PlannedInput& i : c.plan)
      if (i.input.step != 90) sim.give(i.input);
  };
  Simulation whole(s, SimulationConfig{.territories = 1});
  inputs(whole);
  EXPECT_TRUE(whole.advance_to(whole.time_of(kSteps)));
  const std::string expected = hash_hex(whole.state_hash());
  whole.stop();

  Simulation sim(s, SimulationConfig{.territories = 2});
  inputs(sim);
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-joint-motor.ckpt").string();
  EXPECT_EQ(sim.save(path), 40);
  sim.stop();
  const SimulationSnapshot back = read_checkpoint(path);
  ASSERT_EQ(back.inputs.size(), 3u);
  EXPECT_EQ(back.inputs[0].kind, UserInput::Kind::SetJointMotor);
  EXPECT_EQ(back.inputs[0].joint, kSlider);
  EXPECT_EQ(back.inputs[0].motor.velocity, -0.8);
  EXPECT_EQ(back.inputs[1].joint, 5u);
  EXPECT_EQ(back.inputs[2].motor.velocity, 2.5);
  EXPECT_EQ(back.inputs[2].motor.max_impulse, 80.0);
  EXPECT_EQ(back.inputs[2].motor.axis, 5);
  EXPECT_TRUE(back.inputs[2].motor.on);
  for (const JointSnapshot& j : back.state.joints) {
    if (j.description.id == 1) {
      EXPECT_EQ(j.description.motor_velocities[5], -4.0);
    }
    if (j.description.id == 2) {
      EXPECT_FALSE(j.description.motor);
    }
  }
  try {
    encode_checkpoint(back, 9);
    ADD_FAILURE() << "version 9 took a motor input";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 9 cannot hold the input to set the motor of joint " +
                                         std::to_string(kSlider)),
              std::string::npos)
        << e.what();
  }
  for (int k : {1, 4}) {
    SimulationConfig config{.territories = k};
    config.runtime.anticipation = k > 1 ? 8 : 0;
    Simulation resumed = Simulation::resume(path, config);
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
    std::printf("[ motor-row %s ] resumed at step 40 on %d: %s, uninterrupted %s\n", kPrecisionName, k,
                hash_hex(resumed.state_hash()).c_str(), expected.c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), expected) << "K=" << k;
    resumed.stop();
  }
  std::filesystem::remove(path);
}

using test::expect_refused;

// Refusals name the joint and the field, and nothing of them is applied:
// the run with them refused is the run with only the accepted inputs.
TEST(JointMotorScenes, RefusalsNameTheJointAndTheFieldAndApplyNothing) {
  const double nan = std::nan(""), inf = INFINITY;
  Scene s = motor_row();
  // A point-to-point joint between arms 2 and 4 (id 9): no motor.
  Joint p2p;
  p2p.id = 9;
  p2p.kind = JointKind::PointToPoint;
  p2p.body_a = 2, p2p.body_b = 4;
  p2p.frame_a.position = Vec3(3.0, 0.0, 0.0);
  p2p.frame_b.position = Vec3(-3.0, 0.0, 0.0);
  s.joints.push_back(p2p);
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.set_joint_motor(sim.time_of(20), 0, true, 3.0, 1.0);
  sim.remove_joint(sim.time_of(40), 3);
  sim.set_joint_motor(sim.time_of(30), 2, true, -2.0, 1.0);
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 99, true, 1.0, 1.0); },
                 {"set the motor of joint 99 at step 5", "joint: no joint has that id"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 9, true, 1.0, 1.0); },
                 {"joint 9", "joint: joint 9 is a point-to-point joint, which has no motor"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 0, true, 1.0, 1.0, 5); },
                 {"joint 0", "axis: a hinge joint has one motor (no axis)"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 1, true, 1.0, 1.0); },
                 {"joint 1", "axis: a spring-6dof joint's motor needs an axis in 0..5", "got -1"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 1, true, 1.0, 1.0, 6); }, {"joint 1", "axis must be 0..5"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 0, true, nan, 1.0); }, {"joint 0", "velocity must be finite"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 1, true, inf, 1.0, 5); },
                 {"joint 1", "velocity must be finite"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 0, true, 1.0, -1.0); },
                 {"joint 0", "max_impulse must be >= 0 and finite", "got -1"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(5), 0, true, 1.0, inf); }, {"max_impulse must be >= 0"});
  expect_refused([&] { sim.set_joint_motor(sim.time_of(40), 3, true, 1.0, 60.0, 5); },
                 {"joint 3", "joint: joint 3 is removed at step 40 already"});
  // Joint 2 has a motor input at step 30: it cannot be removed before, nor
  // its arm (body 6).
  expect_refused([&] { sim.remove_joint(sim.time_of(25), 2); }, {"remove joint 2", "motor input at the later step 30"});
  expect_refused([&] { sim.remove_body(sim.time_of(25), 6); }, {"remove body 6 at step 25", "later step 30"});
  sim.set_joint_motor(sim.time_of(39), 3, false, 0.0, 0.0, 5);  // before its removal: accepted
  const std::vector<UserInput> log = sim.input_log();
  ASSERT_EQ(log.size(), 4u);
  EXPECT_TRUE(sim.advance_to(sim.time_of(60)));
  Simulation clean(s, SimulationConfig{.territories = 1});
  for (const UserInput& in : log) clean.give(in);
  EXPECT_TRUE(clean.advance_to(clean.time_of(60)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(clean.state_hash()));
  sim.stop();
  clean.stop();
}

TEST(JointMotorScenes, InputFileRefusesBadMotorFields) {
  const auto refused = test::expect_input_file_refused;
  refused(R"({"type": "set_joint_motor", "step": 3, "velocity": 1, "max_impulse": 1})",
          {"set_joint_motor at step 3", "'joint'", "missing"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "max_impulse": 1})", {"joint 2", "'velocity'"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "velocity": 1})", {"'max_impulse'"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "velocity": 1, "max_impulse": -2})",
          {"'max_impulse'", ">= 0"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "velocity": 1, "max_impulse": 1, "axis": 6})",
          {"'axis'", "0..5"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "on": 1, "velocity": 1, "max_impulse": 1})",
          {"'on'", "true or false"});
  refused(R"({"type": "set_joint_motor", "step": 3, "joint": 2, "velocity": 1, "max_impulse": 1, "id": 4})", {"'id'"});
  const std::vector<UserInput> ok = parse_inputs_json(R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "set_joint_motor", "step": 3, "joint": 2, "on": false},
      {"type": "set_joint_motor", "step": 4, "joint": 1, "velocity": -2.5, "max_impulse": 60, "axis": 5}]})",
                                                      "ok.json");
  ASSERT_EQ(ok.size(), 2u);
  EXPECT_EQ(ok[0].kind, UserInput::Kind::SetJointMotor);
  EXPECT_FALSE(ok[0].motor.on);
  EXPECT_EQ(ok[0].motor.axis, -1);
  EXPECT_TRUE(ok[1].motor.on);
  EXPECT_EQ(ok[1].motor.velocity, -2.5);
  EXPECT_EQ(ok[1].motor.max_impulse, 60.0);
  EXPECT_EQ(ok[1].motor.axis, 5);
}

}  // namespace
}  // namespace soda
