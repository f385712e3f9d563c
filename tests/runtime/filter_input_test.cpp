// Collision filters changed by input through the Simulation
// (Simulation::set_collision_filter; docs/embedding.md, "Collision
// filters"): on a pile whose cubes fall in three filter groups, every other
// cube joins a group of its own (queued), takes its scene filter back at the
// frame on screen, and one cube is set to touch nothing at the frame on
// screen. Every frame and the final hash equal the one-territory run with
// every input queued, for K = 1, 2 and 4, lockstep and speculating; a
// kinematic pallet's and elevator's filters the same on the conveyor. Bad
// inputs are refused naming the body, with nothing applied; input files,
// readbacks and checkpoints (version 11, a kinematic body's filter commands
// version 12; older versions refuse them by name) carry the filter. Label
// "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/scene/input_file.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 100;
constexpr BodyId kFalls = 1;  // set to touch nothing at step 80: it falls through the ground
using K = UserInput::Kind;

// cube-pile 150 in three groups, each masking out the next one (as
// collision_filter_test.cpp's pile).
Scene filter_scene() {
  Scene s = test::scene("cube-pile", 150);
  for (Body& b : s.bodies) {
    if (b.is_static) continue;
    b.collision_group = 2u << (b.id % 3);
    b.collision_mask = ~(2u << ((b.id + 1) % 3));
  }
  return s;
}

UserInput filter_input(std::int64_t step, BodyId id, std::uint32_t group, std::uint32_t mask) {
  UserInput in;
  in.kind = K::SetCollisionFilter;
  in.step = step;
  in.id = id;
  in.collision_group = group;
  in.collision_mask = mask;
  return in;
}

// Every other cube: a group of its own at 30 (queued), the scene's filter
// back at 60 (at the frame on screen); kFalls touches nothing from 80 (at
// the frame on screen).
std::vector<test::PlannedInput> plan(const Scene& s) {
  std::vector<test::PlannedInput> out;
  for (const Body& b : s.bodies)
    if (!b.is_static && b.id % 2 == 0) out.push_back({filter_input(30, b.id, 16u, ~16u), false});
  for (const Body& b : s.bodies)
    if (!b.is_static && b.id % 2 == 0) out.push_back({filter_input(60, b.id, b.collision_group, b.collision_mask), true});
  out.push_back({filter_input(80, kFalls, 0u, 0u), true});
  return out;
}

const test::InputReference& reference() {
  static const test::InputReference ref = test::input_reference(filter_scene(), plan(filter_scene()), kSteps);
  return ref;
}

double height_in(const std::vector<ScenePose>& frame, BodyId id) {
  for (const ScenePose& p : frame)
    if (p.id == id) return double(p.position[1]);
  return 1e9;
}

// territories, anticipation
class FilterInputs : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(FilterInputs, EveryFrameAndTheHashEqualOneTerritory) {
  const auto [territories, anticipation] = GetParam();
  const Scene s = filter_scene();
  const test::InputReference& ref = reference();
  test::GameLoop loop(s, territories, anticipation);
  Simulation& sim = loop.sim;
  SceneReader& reader = loop.reader;
  const test::RenderedRun run = loop.run(plan(s), ref.run.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  // The filter of the frame's step: an input at boundary s shows from s + 1.
  const std::optional<BodyAt> before = reader.properties(80, kFalls), after = reader.properties(81, kFalls);
  std::printf("[ filtered cube-pile 150, K %d, anticipation %d ] %zu at the frame on screen, %llu rollbacks; body %u "
              "at y %.2f (step 80), %.2f (step %d); hash %s (one territory %s, without the inputs %s)\n",
              territories, anticipation, run.at_frame, (unsigned long long)sim.rollbacks(), kFalls,
              height_in(ref.run.frames[80], kFalls), height_in(ref.run.frames[kSteps], kFalls), kSteps,
              hash_hex(hash).c_str(), hash_hex(ref.run.hash).c_str(), hash_hex(ref.no_input_hash).c_str());
  sim.stop();
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(run.at_frame, 76u);  // 75 cubes back to their filter at 60, kFalls at 80
  EXPECT_GT(sim.rollbacks(), 0u);
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.run.hash));
  EXPECT_NE(ref.run.hash, ref.no_input_hash);  // the inputs changed the run
  ASSERT_TRUE(before && after);
  EXPECT_EQ(before->collision_mask, ~(2u << ((kFalls + 1) % 3)));
  EXPECT_EQ(after->collision_mask, 0u);
  // Resting on the ground or a cube at 80, below the ground 20 steps later.
  EXPECT_GT(height_in(ref.run.frames[80], kFalls), 0.3);
  EXPECT_LT(height_in(ref.run.frames[kSteps], kFalls), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Simulation, FilterInputs, ::testing::Combine(::testing::Values(1, 2, 4), ::testing::Values(0, 8)),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           return "K" + std::to_string(std::get<0>(info.param)) + "_anticipation" +
                                  std::to_string(std::get<1>(info.param));
                         });

// A kinematic body's filter by input: on the conveyor, a pallet carrying
// boxes is set to touch nothing at the frame on screen (its boxes drop
// into it), the elevator is set to touch nothing at the frame on screen a
// few steps later, and the pallet takes its scene filter back (queued).
// Every frame and the hash equal the one-territory run with every input
// queued, K = 2 and 4, lockstep and speculating: the elevator's input rolls
// every world back to a step between the pallet's two commands, where a
// rebuilt world must take the filter then in effect, not the scene's. The
// speculating K = 4 run three times (speculation's timing differs).
constexpr int kConveyorSteps = 120;
constexpr BodyId kPallet = 2, kElevator = 6;
constexpr std::int64_t kDrop = 40, kElevatorOff = 44, kCatch = 50;

const Scene& conveyor() {
  static const Scene s = test::scene("conveyor", 72);
  return s;
}

std::vector<test::PlannedInput> kinematic_plan() {
  const Body& pallet = conveyor().bodies[kPallet];
  return {{filter_input(kDrop, kPallet, pallet.collision_group, 0u), true},
          {filter_input(kElevatorOff, kElevator, 4u, 4u), true},
          {filter_input(kCatch, kPallet, pallet.collision_group, pallet.collision_mask), false}};
}

// The lowest of `riders` at kCatch in `frames`.
double lowest_riding_box(const std::vector<std::vector<ScenePose>>& frames, const std::vector<BodyId>& riders) {
  double y = 1e9;
  for (BodyId id : riders) y = std::min(y, height_in(frames[kCatch], id));
  return y;
}

class KinematicFilterInputs : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(KinematicFilterInputs, EveryFrameAndTheHashEqualOneTerritory) {
  const auto [territories, anticipation] = GetParam();
  ASSERT_TRUE(conveyor().bodies[kPallet].kinematic && conveyor().bodies[kElevator].kinematic);
  static const test::InputReference ref = test::input_reference(conveyor(), kinematic_plan(), kConveyorSteps);
  static const test::QueuedRun plain = test::queued_run(conveyor(), {}, kConveyorSteps);
  // The boxes riding the pallet at kDrop: above its top (0.7 m) and within
  // its 1.5 m x 1.0 m, in the run without inputs.
  std::vector<BodyId> riders;
  Body pallet_then = conveyor().bodies[kPallet];
  const Pose at = kinematic_pose(pallet_then, double(kDrop) * conveyor().settings.dt);
  for (const ScenePose& p : plain.frames[kDrop])
    if (std::abs(double(p.position[0]) - at.position.x()) < 1.4 && std::abs(double(p.position[2]) - at.position.z()) < 0.9 &&
        double(p.position[1]) > 0.7 && double(p.position[1]) < 1.2)
      riders.push_back(p.id);
  const int rounds = territories == 4 && anticipation > 0 ? 3 : 1;
  for (int round = 0; round < rounds; ++round) {
    test::GameLoop loop(conveyor(), territories, anticipation);
    Simulation& sim = loop.sim;
    const test::RenderedRun run = loop.run(kinematic_plan(), ref.run.frames, kConveyorSteps);
    const std::uint64_t hash = sim.state_hash();
    const std::optional<BodyAt> before = loop.reader.properties(kDrop, kPallet),
                                off = loop.reader.properties(kCatch, kPallet),
                                back = loop.reader.properties(kCatch + 1, kPallet),
                                elevator = loop.reader.properties(kElevatorOff + 1, kElevator);
    std::printf("[ conveyor 72 %s, K %d, anticipation %d, round %d ] %zu at the frame on screen, %llu rollbacks; "
                "%zu boxes on the pallet at %lld, the lowest at y %.2f at %lld (%.2f without the inputs); hash %s "
                "(one territory %s, without the inputs %s)\n",
                kPrecisionName, territories, anticipation, round, run.at_frame,
                (unsigned long long)sim.rollbacks(), riders.size(), (long long)kDrop,
                lowest_riding_box(ref.run.frames, riders), (long long)kCatch, lowest_riding_box(plain.frames, riders),
                hash_hex(hash).c_str(), hash_hex(ref.run.hash).c_str(), hash_hex(ref.no_input_hash).c_str());
    sim.stop();
    EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                                 << (run.bad.empty() ? "" : run.bad.front());
    EXPECT_EQ(run.at_frame, 2u);
    EXPECT_EQ(hash_hex(hash), hash_hex(ref.run.hash));
    ASSERT_TRUE(before && off && back && elevator);
    EXPECT_EQ(before->collision_mask, conveyor().bodies[kPallet].collision_mask);
    EXPECT_EQ(off->collision_mask, 0u);
    EXPECT_EQ(back->collision_mask, conveyor().bodies[kPallet].collision_mask);
    EXPECT_EQ(elevator->collision_group, 4u);
  }
  // The inputs changed the run: the pallet's boxes dropped through it.
  EXPECT_NE(ref.run.hash, ref.no_input_hash);
  ASSERT_FALSE(riders.empty());
  EXPECT_LT(lowest_riding_box(ref.run.frames, riders), lowest_riding_box(plain.frames, riders) - 0.08);
}

INSTANTIATE_TEST_SUITE_P(Simulation, KinematicFilterInputs,
                         ::testing::Combine(::testing::Values(2, 4), ::testing::Values(0, 8)),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           return "K" + std::to_string(std::get<0>(info.param)) + "_anticipation" +
                                  std::to_string(std::get<1>(info.param));
                         });

// Saved between the pallet's two commands: the file holds the pallet's
// filter command (version 12) and the queued ones; resumed on 1 and 4
// territories it ends on the uninterrupted hash. Version 11 has no field
// for a kinematic body's filter inputs and refuses it by name.
TEST(SimulationFilterInputs, CheckpointsCarryAKinematicBodysFilter) {
  Simulation sim(conveyor(), SimulationConfig{.territories = 2});
  for (const test::PlannedInput& p : kinematic_plan()) sim.give(p.input);
  EXPECT_TRUE(sim.advance_to(sim.time_of(kDrop + 2)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-kinematic-filter.ckpt").string();
  EXPECT_EQ(sim.save(path), kDrop + 2);
  sim.stop();
  const SimulationSnapshot snap = read_checkpoint(path);
  EXPECT_EQ(checkpoint_header(encode_checkpoint(snap)).version, kCheckpointVersion);
  const test::QueuedRun uninterrupted = test::queued_run(conveyor(), kinematic_plan(), kConveyorSteps);
  for (int territories : {1, 4}) {
    Simulation resumed = Simulation::resume(path, SimulationConfig{.territories = territories});
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kConveyorSteps)));
    std::printf("[ conveyor, the pallet's filter saved at %lld, resumed on %d ] %s (uninterrupted %s)\n",
                (long long)(kDrop + 2), territories, hash_hex(resumed.state_hash()).c_str(),
                hash_hex(uninterrupted.hash).c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(uninterrupted.hash));
  }
  std::filesystem::remove(path);
  try {
    encode_checkpoint(snap, 11);
    ADD_FAILURE() << "version 11 took a kinematic body's filter input";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 11 cannot hold body " + std::to_string(kPallet) +
                                         " (its collision filter inputs)"),
              std::string::npos)
        << e.what();
  }
}

TEST(SimulationFilterInputs, BadInputsAreRefusedNamingTheBody) {
  const Scene s = filter_scene();
  BodyId ground = 0;
  for (const Body& b : s.bodies)
    if (b.is_static) ground = b.id;
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.remove_body(sim.time_of(10), 4);
  test::expect_refused([&] { sim.set_collision_filter(sim.time_of(5), ground, 2u, 2u); },
                       {"collision filter of body " + std::to_string(ground), "static"});
  test::expect_refused([&] { sim.set_collision_filter(sim.time_of(5), test::unused_id(s), 2u, 2u); },
                       {"no body has that id"});
  test::expect_refused([&] { sim.set_collision_filter(sim.time_of(20), 4, 2u, 2u); },
                       {"collision filter of body 4", "not in the scene then"});
  EXPECT_EQ(sim.input_log().size(), 1u);  // the removal only
  EXPECT_TRUE(sim.advance_to(sim.time_of(30)));

  const Scene conveyor = test::scene("conveyor", 8);
  BodyId platform = kNoBody;
  for (const Body& b : conveyor.bodies)
    if (b.kinematic) platform = b.id;
  ASSERT_NE(platform, kNoBody);
  Simulation moving(conveyor, SimulationConfig{.territories = 2});
  test::expect_refused([&] { moving.set_friction(moving.time_of(5), platform, 0.1); },
                       {"body " + std::to_string(platform), "kinematic", "set_collision_filter"});
  moving.set_collision_filter(moving.time_of(5), platform, 2u, 2u);  // a kinematic body's filter changes
  EXPECT_EQ(moving.input_log().size(), 1u);
}

TEST(SimulationFilterInputs, InputFilesCarryTheFilter) {
  const std::vector<UserInput> read = parse_inputs_json(
      R"({"format": "soda-inputs", "version": 1, "inputs": [{"type": "set_collision_filter", "step": 3, "id": 7,
          "group": 4294967295, "mask": 0}]})",
      "ok.json");
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].kind, K::SetCollisionFilter);
  EXPECT_EQ(read[0].collision_group, 0xffffffffu);
  EXPECT_EQ(read[0].collision_mask, 0u);
  const std::vector<UserInput> again = parse_inputs_json(inputs_to_json(read), "again.json");
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].collision_group, 0xffffffffu);
  EXPECT_EQ(again[0].collision_mask, 0u);
  const auto refused = test::expect_input_file_refused;
  refused(R"({"type": "set_collision_filter", "step": 3, "id": 7, "group": -1, "mask": 1})",
          {"body 7", "'group'", "[0, 2^32)"});
  refused(R"({"type": "set_collision_filter", "step": 3, "id": 7, "group": 1, "mask": 4294967296})",
          {"body 7", "'mask'", "[0, 2^32)"});
  refused(R"({"type": "set_collision_filter", "step": 3, "id": 7, "group": "all", "mask": 1})", {"'group'"});
  refused(R"({"type": "set_collision_filter", "step": 3, "id": 7, "group": 1})", {"'mask'", "missing"});
  refused(R"({"type": "set_collision_filter", "step": 3, "id": 7, "group": 1, "mask": 1, "layer": 2})",
          {"'layer'", "unknown field"});
}

// Saved at step 40 with the filters of steps 60 and 80 queued, resumed on 1
// and 4 territories: the uninterrupted hash. Version 10 cannot hold the
// input: refused by name.
TEST(SimulationFilterInputs, CheckpointsCarryQueuedFilters) {
  const Scene s = filter_scene();
  Simulation sim(s, SimulationConfig{.territories = 2});
  for (const test::PlannedInput& p : plan(s)) sim.give(p.input);
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-filters.ckpt").string();
  EXPECT_EQ(sim.save(path), 40);
  sim.stop();
  const SimulationSnapshot snap = read_checkpoint(path);
  EXPECT_EQ(checkpoint_header(encode_checkpoint(snap)).version, kCheckpointVersion);
  for (int territories : {1, 4}) {
    Simulation resumed = Simulation::resume(path, SimulationConfig{.territories = territories});
    EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
    std::printf("[ filters, saved at 40, resumed on %d ] %s (uninterrupted %s)\n", territories,
                hash_hex(resumed.state_hash()).c_str(), hash_hex(reference().run.hash).c_str());
    EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(reference().run.hash));
  }
  std::filesystem::remove(path);
  try {
    encode_checkpoint(snap, 10);
    ADD_FAILURE() << "version 10 took a collision filter input";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 10 cannot hold the input to set the collision filter of body"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace soda
