// Kinematic bodies moved by input (Simulation::set_kinematic_target,
// Simulation::set_pose; docs/scene-format.md, "Kinematic bodies") and
// set_pose of dynamic bodies keep decomposition invariance: on the conveyor
// scene, an elevator driven every step from the application's loop, a pallet
// stopped and teleported, a box teleported — given up front, or late under
// speculation (each a rollback) — end with the one-territory hash for
// K = 1, 2, 4, speculating, under SyncTest and after a checkpoint. Bad inputs
// are refused naming the body and the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <condition_variable>
#include <mutex>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "runtime/simulation_test_util.h"
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
  const UserInput last = plan()[200 - 30];  // a copy: plan() returns a new vector
  ASSERT_EQ(last.step, 200);
  for (const BodyState& b : sim.body_states()) {
    if (b.id != kElevator) continue;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(b.origin[k], btScalar(last.linear[k])) << "axis " << k;
  }
  sim.stop();
}

// Given up front: K = 2, 4, lockstep and speculating, and in a
// PartitionedWorld under SyncTest (every step restored and re-run).
TEST(KinematicInputs, EveryTerritoryCountGivesTheOneTerritoryHash) {
  for (int k : {2, 4}) EXPECT_EQ(hash_hex(api_hash(plan(), k)), reference()) << "K=" << k;
  for (int anticipation : test::sync_test_anticipations()) {
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

// Given late: the worlds run on in the background, speculating, while a
// reader holds frame 120 on screen; once some world has passed step 121,
// the inputs of steps 120 on arrive (those behind it roll every world back).
TEST(KinematicInputs, LateInputsUnderSpeculationRollBackToTheOneTerritoryHash) {
  for (int k : {2, 4}) {
    test::Progress progress;
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

// What an application reads back sees the platforms where the worlds have
// them: every frame's SceneFrame::kinematic equals, bit for bit, the
// kinematic bodies' states of a one-territory run at that step (path and
// inputs alike); a query's ray finds the elevator at its raised height, not
// where the scene put it; a static sensor above the elevator reports it
// once it has risen into it. Read while 4 territories speculate.
TEST(KinematicInputs, ReadersQueriesAndSensorsSeeThePlatformsWhereTheWorldsHaveThem) {
  const std::vector<std::int64_t> checks{0, 1, 30, 31, 45, 91, 100, 150, 151, 200, 201, kSteps};
  // The reference: kinematic states of one territory, step by step.
  std::vector<std::vector<ScenePose>> expected;
  {
    Simulation one(conveyor(), SimulationConfig{.territories = 1});
    for (const UserInput& in : plan()) one.give(in);
    for (std::int64_t s : checks) {
      ASSERT_TRUE(one.advance_to(one.time_of(s)));
      std::vector<ScenePose> k;
      for (const BodyState& b : one.body_states())
        for (const Body& d : conveyor().bodies)
          if (d.id == b.id && d.kinematic) k.push_back(body_pose(b));
      expected.push_back(std::move(k));
    }
    one.stop();
  }
  // A sensor 1.5 m above the elevator's rest, where the plan lifts it.
  Scene scene = conveyor();
  const Body& lift = conveyor().bodies[kElevator];
  ASSERT_TRUE(lift.kinematic);
  Body zone;
  zone.id = 100000;
  zone.is_static = true;
  zone.sensor = true;
  zone.shape = Shape::box(Vec3(0.3, 0.05, 0.3));
  zone.position = lift.position + Vec3(0.0, 1.5, 0.0);
  scene.bodies.push_back(zone);

  SimulationConfig config{.territories = 4};
  config.runtime.anticipation = 8;
  Simulation sim(scene, config);
  for (const UserInput& in : plan()) sim.give(in);
  SceneReader reader = sim.add_reader();
  SceneQuery query = sim.add_query();
  SensorReader sensors = sim.add_sensor_reader();
  sim.start(sim.time_of(kSteps));
  QueryFilter statics_only;
  statics_only.dynamics = false;
  for (std::size_t c = 0; c < checks.size(); ++c) {
    const std::int64_t s = checks[c];
    const double t = sim.time_of(s);
    const std::optional<SceneFrame> frame = reader.read_at(t);
    ASSERT_TRUE(frame.has_value()) << "step " << s;
    ASSERT_EQ(frame->kinematic.size(), expected[c].size());
    for (std::size_t i = 0; i < expected[c].size(); ++i) {
      const ScenePose &got = frame->kinematic[i], &want = expected[c][i];
      EXPECT_EQ(got.id, want.id);
      EXPECT_EQ(0, std::memcmp(got.position, want.position, sizeof got.position)) << "step " << s << " body " << got.id;
      EXPECT_EQ(0, std::memcmp(got.orientation, want.orientation, sizeof got.orientation)) << "step " << s;
      EXPECT_EQ(0, std::memcmp(got.linear_velocity, want.linear_velocity, sizeof got.linear_velocity)) << "step " << s;
      EXPECT_EQ(got.sleeping, want.sleeping) << "step " << s << " body " << got.id;
    }
    const ScenePose* elevator = frame->find_kinematic(kElevator);
    ASSERT_NE(elevator, nullptr);
    const std::optional<BodyAt> at = reader.body_at(t, kElevator);
    ASSERT_TRUE(at.has_value());
    EXPECT_EQ(at->owner, kNoWorld);
    EXPECT_EQ(at->pose.position[1], elevator->position[1]);
    // A level ray through the elevator's middle at its frame height hits its
    // side (x = 5 - 1.5); through where the scene put it, nothing once it
    // has risen more than its thickness.
    const double y = elevator->position[1];
    const auto side = query.ray_cast(t, Vec3(-20.0, y, lift.position.z()), Vec3(20.0, y, lift.position.z()),
                                     statics_only);
    ASSERT_TRUE(side.has_value());
    EXPECT_EQ(side->step, s);
    ASSERT_FALSE(side->items.empty()) << "step " << s;
    EXPECT_EQ(side->items[0].id, kElevator) << "step " << s;
    // The plan turns it about y by θ: the face is 1.5 / cos θ from its centre.
    const double theta = 2.0 * std::atan2(double(elevator->orientation[1]), double(elevator->orientation[3]));
    // (Bullet's ray test against a convex shape is good to a few mm; unturned
    // it would be 1.5 m.)
    EXPECT_NEAR(side->items[0].point.x(), elevator->position[0] - 1.5 / std::cos(theta), 0.01) << "step " << s;
    const double rest = lift.position.y();
    if (y > rest + 0.25) {
      const auto below = query.ray_cast(t, Vec3(-20.0, rest, lift.position.z()),
                                        Vec3(20.0, rest, lift.position.z()), statics_only);
      ASSERT_TRUE(below.has_value());
      for (const QueryHit& h : below->items) EXPECT_NE(h.id, kElevator) << "step " << s;
    }
    // The sensor holds the elevator exactly when its box reaches the zone
    // (the elevator's top at y + 0.1, the zone's bottom at rest + 1.45).
    const std::optional<SensorStep> sensed = sensors.read_step(s);
    ASSERT_TRUE(sensed.has_value());
    const bool inside = std::find(sensed->inside.begin(), sensed->inside.end(),
                                  SensorOverlap{zone.id, kElevator}) != sensed->inside.end();
    const double gap = (rest + 1.45) - (y + 0.1);
    if (std::abs(gap) > 1e-3) {
      EXPECT_EQ(inside, gap < 0.0) << "step " << s << " elevator at " << y;
    }
    std::printf("[ conveyor 72 %s, K 4, anticipation 8 ] step %lld: elevator at y %.4f, sensor %s\n",
                kPrecisionName, static_cast<long long>(s), y, inside ? "holds it" : "empty");
  }
  sim.stop();
}

// Contact events with platforms (a box on a pallet, the elevator's load):
// the stream of one territory, for 4 territories speculating on one thread
// (the worlds run round-robin, so some run ahead and roll back), bit for bit.
std::vector<ContactStep> contact_stream(int territories, int threads, std::uint64_t* rollbacks) {
  SimulationConfig config{.territories = territories, .threads = threads, .contact_events = true};
  config.runtime.anticipation = territories > 1 ? 8 : 0;
  Simulation sim(conveyor(), config);
  for (const UserInput& in : plan()) sim.give(in);
  std::vector<ContactStep> out;
  std::thread reader([&, r = sim.add_contact_reader()]() mutable {
    for (int t = 0; t <= kSteps; ++t) {
      std::optional<ContactStep> st = r.read_step(t);
      if (!st) break;
      out.push_back(std::move(*st));
    }
  });
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  reader.join();
  EXPECT_EQ(hash_hex(sim.state_hash()), reference());
  if (rollbacks) *rollbacks = sim.rollbacks();
  sim.stop();
  return out;
}

TEST(KinematicInputs, ContactEventsWithPlatformsAreTheOneTerritoryStream) {
  const std::vector<ContactStep> one = contact_stream(1, 1, nullptr);
  ASSERT_EQ(one.size(), static_cast<std::size_t>(kSteps + 1));
  std::size_t with_platform = 0, ends_with_platform = 0;
  for (const ContactStep& st : one)
    for (const ContactEvent& e : st.events) {
      const bool platform = conveyor().bodies[e.a].kinematic;  // ids are indices; a < b, platforms first
      with_platform += platform;
      ends_with_platform += platform && e.kind == ContactEventKind::End;
    }
  EXPECT_GT(with_platform, 20u);
  EXPECT_GT(ends_with_platform, 0u);  // the teleported box leaves its pallet
  std::uint64_t rollbacks = 0;
  const std::vector<ContactStep> four = contact_stream(4, 1, &rollbacks);
  std::printf("[ conveyor 72 %s ] %zu events with a platform (%zu ends); K 4 speculating on one thread: "
              "%llu rollbacks, stream %016llx, one territory %016llx\n",
              kPrecisionName, with_platform, ends_with_platform, static_cast<unsigned long long>(rollbacks),
              static_cast<unsigned long long>(contact_stream_hash(four)),
              static_cast<unsigned long long>(contact_stream_hash(one)));
  EXPECT_EQ(contact_stream_hash(four), contact_stream_hash(one));
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
