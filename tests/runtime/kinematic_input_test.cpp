// Kinematic bodies moved by input (Simulation::set_kinematic_target,
// Simulation::set_pose; docs/scene-format.md, "Kinematic bodies") and
// set_pose of dynamic bodies keep decomposition invariance: on the conveyor
// scene, an elevator driven every step from the application's loop, a pallet
// stopped and teleported, a box teleported — given up front, or late under
// speculation (each a rollback) — end with the one-territory hash for
// K = 1, 2, 4, speculating, under SyncTest and after a checkpoint. Bad inputs
// are refused naming the body and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <mutex>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/runtime/simulation.h"

namespace soda {
namespace {

constexpr int kSteps = 240;
constexpr BodyId kPallet = 2;
constexpr BodyId kElevator = 6;

const Scene& conveyor() {
  static const Scene s = test::scene("conveyor", 72);
  return s;
}

BodyId first_box() {
  for (const Body& b : conveyor().bodies)
    if (!b.is_static) return b.id;
  return 0;
}

UserInput pose_input(UserInput::Kind kind, std::int64_t step, BodyId id, const Vec3& at,
                     const Quat& q = Quat::Identity()) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  in.linear = at;
  in.orientation = q;
  return in;
}

// The application's loop drives the elevator up and down (1.5 m, a 4 s
// period) from step 30 to 200, turning it as it goes; the pallet stops at
// step 90 (its target: where it is asked to stay) and is teleported back at
// 150; a box is teleported 1 m up at 60.
std::vector<UserInput> plan() {
  std::vector<UserInput> out;
  const Body& lift = conveyor().bodies[kElevator];
  for (int step = 30; step <= 200; ++step) {
    const double t = (step - 30) / 60.0;
    const double y = lift.position.y() + 0.75 * (1.0 - std::cos(2.0 * M_PI * t / 4.0));
    out.push_back(pose_input(UserInput::Kind::SetKinematicTarget, step, kElevator,
                             Vec3(lift.position.x(), y, lift.position.z()),
                             Quat(Eigen::AngleAxisd(0.1 * t, Vec3::UnitY()))));
  }
  out.push_back(pose_input(UserInput::Kind::SetKinematicTarget, 90, kPallet, Vec3(2.0, 0.6, -4.5)));
  out.push_back(pose_input(UserInput::Kind::SetPose, 150, kPallet, Vec3(-6.0, 0.6, -4.5)));
  const Body& box = *std::find_if(conveyor().bodies.begin(), conveyor().bodies.end(),
                                  [](const Body& b) { return b.id == first_box(); });
  out.push_back(pose_input(UserInput::Kind::SetPose, 60, box.id, box.position + Vec3(0.0, 1.0, 0.0)));
  for (std::size_t i = 0; i < out.size(); ++i) out[i].sequence = i;
  return out;
}

std::uint64_t api_hash(const std::vector<UserInput>& inputs, int territories) {
  Simulation sim(conveyor(), SimulationConfig{.territories = territories});
  for (const UserInput& in : inputs) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const std::uint64_t h = sim.state_hash();
  sim.stop();
  return h;
}

const std::string& reference() {
  static const std::string h = hash_hex(api_hash(plan(), 1));
  return h;
}

TEST(KinematicInputs, TheInputsMoveThePlatforms) {
  const std::string none = hash_hex(api_hash({}, 1));
  EXPECT_NE(reference(), none);
  // The elevator is where the last target put it (held after step 201).
  Simulation sim(conveyor(), SimulationConfig{.territories = 2});
  for (const UserInput& in : plan()) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const UserInput& last = plan()[200 - 30];
  ASSERT_EQ(last.step, 200);
  for (const BodyState& b : sim.body_states())
    if (b.id == kElevator)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(b.origin[k], btScalar(last.linear[k])) << "axis " << k;
  sim.stop();
}

// Given up front: K = 2, 4, lockstep and speculating, and in a
// PartitionedWorld under SyncTest (every step restored and re-run).
TEST(KinematicInputs, EveryTerritoryCountGivesTheOneTerritoryHash) {
  for (int k : {2, 4}) EXPECT_EQ(hash_hex(api_hash(plan(), k)), reference()) << "K=" << k;
  for (int anticipation : {0, 8}) {
    PartitionedOptions o;
    o.runtime.validate = true;
    o.runtime.anticipation = anticipation;
    o.runtime.parking = true;
    o.sync_test = 1;
    o.inputs = plan();
    PartitionedWorld w(conveyor(), make_partition("kmeans", conveyor(), 4, GridOptions{}), o);
    w.step(kSteps);
    std::printf("[ conveyor 72 %s, K 4, sync-test 1, anticipation %d ] %llu sync rollbacks; %s, API %s\n",
                kPrecisionName, anticipation, static_cast<unsigned long long>(w.sync_rollbacks()),
                hash_hex(w.state_hash()).c_str(), reference().c_str());
    EXPECT_GT(w.sync_rollbacks(), 0u);
    EXPECT_EQ(hash_hex(w.state_hash()), reference()) << "anticipation " << anticipation;
  }
}

// The newest scene step any world has finished (a condition variable,
// never a clock).
struct Progress {
  std::mutex mutex;
  std::condition_variable cv;
  std::int64_t newest = 0;
  std::function<void(WorldId, std::int64_t)> hook() {
    return [this](WorldId, std::int64_t step) {
      std::lock_guard lock(mutex);
      if (step > newest) newest = step;
      cv.notify_all();
    };
  }
  void wait_past(std::int64_t step) {
    std::unique_lock lock(mutex);
    cv.wait(lock, [&] { return newest > step; });
  }
};

// Given late: the worlds run on in the background, speculating, while a
// reader holds frame 120 on screen; once some world has passed step 121,
// the inputs of steps 120 on arrive (those behind it roll every world back).
TEST(KinematicInputs, LateInputsUnderSpeculationRollBackToTheOneTerritoryHash) {
  for (int k : {2, 4}) {
    Progress progress;
    SimulationConfig config{.territories = k, .buffer_capacity = 64, .past_inputs = true};
    config.runtime.anticipation = 8;
    config.after_step = progress.hook();
    Simulation sim(conveyor(), config);
    SceneReader reader = sim.add_reader();
    const std::vector<UserInput> all = plan();
    for (const UserInput& in : all)
      if (in.step < 120) sim.give(in);
    sim.start(sim.time_of(kSteps));
    for (int f = 0; f <= 120; ++f) EXPECT_TRUE(reader.read_at(sim.time_of(f)).has_value());
    progress.wait_past(121);
    for (const UserInput& in : all)
      if (in.step >= 120) sim.give(in);
    // The reader goes on to the end (it holds the commit horizon back).
    for (int f = 121; f <= kSteps; ++f) EXPECT_TRUE(reader.read_at(sim.time_of(f)).has_value());
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    std::printf("[ conveyor 72 %s, K %d, anticipation 8 ] late inputs: %llu rollbacks; %s, one territory %s\n",
                kPrecisionName, k, static_cast<unsigned long long>(sim.rollbacks()),
                hash_hex(sim.state_hash()).c_str(), reference().c_str());
    EXPECT_GT(sim.rollbacks(), 0u);
    EXPECT_EQ(hash_hex(sim.state_hash()), reference()) << "K=" << k;
    sim.stop();
  }
}

// Saved at step 120 (the elevator's commands so far in its record, later
// inputs queued) and resumed on other territories: the uninterrupted hash.
TEST(KinematicInputs, CheckpointsCarryTheCommands) {
  Simulation sim(conveyor(), SimulationConfig{.territories = 2});
  for (const UserInput& in : plan()) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(120)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-kinematic.ckpt").string();
  EXPECT_EQ(sim.save(path), 120);
  sim.stop();
  const SimulationSnapshot snap = read_checkpoint(path);
  EXPECT_THROW(encode_checkpoint(snap, 6), CheckpointError);  // version 6 has no kinematic bodies
  Simulation resumed = Simulation::resume(path, SimulationConfig{.territories = 4});
  std::filesystem::remove(path);
  EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
  EXPECT_EQ(hash_hex(resumed.state_hash()), reference());
  resumed.stop();
}

// The input log is an input file: read back and given to a fresh run, the
// same hash.
TEST(KinematicInputs, InputLogReplays) {
  const std::vector<UserInput> back = parse_inputs_json(inputs_to_json(plan()), "log");
  ASSERT_EQ(back.size(), plan().size());
  EXPECT_EQ(hash_hex(api_hash(back, 2)), reference());
}

TEST(KinematicInputs, BadInputsAreRefusedNamingTheBodyAndTheField) {
  Simulation sim(conveyor(), SimulationConfig{.territories = 2});
  auto refused = [&](const std::function<void()>& call, const std::vector<std::string>& needles) {
    try {
      call();
      ADD_FAILURE() << "accepted; expected: " << needles.front();
    } catch (const std::invalid_argument& e) {
      std::printf("refused: %s\n", e.what());
      for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  };
  const BodyId box = first_box();
  const double t = sim.time_of(5);
  const Pose up{Vec3(0, 2, 0), Quat::Identity()};
  refused([&] { sim.set_kinematic_target(t, 99999, up); }, {"body 99999", "no body has that id"});
  refused([&] { sim.set_kinematic_target(t, box, up); },
          {"body " + std::to_string(box), "is not kinematic"});
  refused([&] { sim.set_kinematic_target(t, 0, up); }, {"body 0", "is not kinematic"});
  refused([&] { sim.set_pose(t, 0, up); }, {"body 0", "static"});
  refused([&] { sim.set_kinematic_target(t, kElevator, Pose{Vec3(0, std::nan(""), 0), Quat::Identity()}); },
          {"body " + std::to_string(kElevator), "position must be finite"});
  refused([&] { sim.set_pose(t, box, Pose{Vec3(0, 1, 0), Quat(0, 0, 0, 0)}); },
          {"body " + std::to_string(box), "orientation must be a non-zero quaternion"});
  refused([&] { sim.set_pose(t, kElevator, Pose{Vec3(0, 1, 0), Quat(std::nan(""), 0, 0, 1)}); },
          {"body " + std::to_string(kElevator), "orientation must be finite"});
  refused([&] { sim.set_velocity(t, kElevator, Vec3(1, 0, 0)); },
          {"body " + std::to_string(kElevator), "is kinematic"});
  EXPECT_TRUE(sim.input_log().empty());  // nothing of a refused input was taken
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  sim.stop();
}

}  // namespace
}  // namespace soda
