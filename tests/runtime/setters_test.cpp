// Setters and readbacks through the Simulation (docs/embedding.md,
// "Setters and readbacks"): the scene's gravity and a body's mass,
// friction, restitution and user data changed at a time, and a body read
// back by id at a committed step. The result depends only on the steps the
// inputs name: every frame and the final hash equal the one-territory run
// with every input queued, for K = 1, 2 and 4, lockstep and speculating,
// with inputs at the frame on screen (each a rollback). Bad values are
// refused naming the body and the field, with nothing applied; the input
// log replays to the same hash; checkpoints (version 4, and versions 1 and 3 for
// a run without the new inputs) resume to it. Label "concurrency"
// (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "runtime/setter_plan.h"
#include "runtime/simulation_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr int kSteps = 100;
using K = UserInput::Kind;

Scene setter_scene() { return test::scene("cube-pile", 120); }

// The inputs given at the frame on screen (each a rollback): a friction, a
// gravity and a restitution change late in the run; the earlier ones are
// queued, so that ghosts and border islands live through their changes.
bool at_frame(const UserInput& in) {
  return (in.kind == K::SetFriction && in.step == 50) || (in.kind == K::SetGravity && in.step == 70) ||
         (in.kind == K::SetRestitution && in.step == 75);
}

// The setter plan, each input marked at the frame on screen or queued.
std::vector<test::PlannedInput> planned(const Scene& s) {
  std::vector<test::PlannedInput> out;
  for (const UserInput& in : test::setter_plan(s)) out.push_back({in, at_frame(in)});
  return out;
}

const test::InputReference& reference() {
  static const test::InputReference ref = test::input_reference(setter_scene(), planned(setter_scene()), kSteps);
  return ref;
}

// territories, anticipation
class Setters : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(Setters, EveryFrameAndTheHashEqualOneTerritory) {
  const auto [territories, anticipation] = GetParam();
  const Scene s = setter_scene();
  const test::InputReference& ref = reference();
  const std::vector<test::PlannedInput> plan = planned(s);

  test::GameLoop loop(s, territories, anticipation);
  Simulation& sim = loop.sim;
  SceneReader& reader = loop.reader;
  const test::RenderedRun run = loop.run(plan, ref.run.frames, kSteps);
  const std::uint64_t hash = sim.state_hash();
  // Readbacks at the last step: the plan's tags and masses, whatever K.
  const BodyId heavy = test::first_dynamic(s);
  std::optional<BodyAt> b = reader.body_at(sim.time_of(kSteps), heavy);
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->step, kSteps);
  EXPECT_EQ(b->user_data, test::plan_tag(heavy));
  EXPECT_EQ(b->mass, 6.0);
  EXPECT_EQ(b->friction, 1.2);
  const std::vector<ScenePose>& last = ref.run.frames[kSteps];
  auto in_ref = std::find_if(last.begin(), last.end(), [&](const ScenePose& p) { return p.id == heavy; });
  ASSERT_NE(in_ref, last.end());
  EXPECT_TRUE(test::same_bits(b->pose, *in_ref));
  std::printf("[ cube-pile 120, K %d, anticipation %d ] %zu inputs, %zu at the frame on screen, %llu rollbacks; "
              "hash %s (one territory %s, without the inputs %s)\n",
              territories, anticipation, plan.size(), run.at_frame, (unsigned long long)sim.rollbacks(),
              hash_hex(hash).c_str(), hash_hex(ref.run.hash).c_str(), hash_hex(ref.no_input_hash).c_str());
  sim.stop();
  EXPECT_TRUE(run.bad.empty()) << run.bad.size() << " bad frames, the first: "
                               << (run.bad.empty() ? "" : run.bad.front());
  EXPECT_EQ(run.at_frame, 3u);
  EXPECT_EQ(sim.rollbacks(), run.at_frame);  // each at a step a world had passed: rolled back, re-run
  EXPECT_GT(sim.rollbacks(), 0u);
  EXPECT_EQ(hash_hex(hash), hash_hex(ref.run.hash));
  EXPECT_NE(ref.run.hash, ref.no_input_hash);  // the inputs changed the run
}

INSTANTIATE_TEST_SUITE_P(Simulation, Setters,
                         ::testing::Combine(::testing::Values(1, 2, 4), ::testing::Values(0, 8)),
                         [](const ::testing::TestParamInfo<std::tuple<int, int>>& info) {
                           return "K" + std::to_string(std::get<0>(info.param)) + "_anticipation" +
                                  std::to_string(std::get<1>(info.param));
                         });

// Each setter alone changes the run (a test of the test: an input the
// worlds ignored would pass the comparisons above).
TEST(SimulationSetters, EachKindChangesTheRun) {
  const Scene s = setter_scene();
  const BodyId id = test::first_dynamic(s);
  auto hash_with = [&](const std::vector<UserInput>& inputs) {
    Simulation sim(s, SimulationConfig{.territories = 2});
    for (const UserInput& in : inputs) sim.give(in);
    EXPECT_TRUE(sim.advance_to(sim.time_of(80)));
    return sim.state_hash();
  };
  const std::uint64_t none = hash_with({});
  EXPECT_NE(hash_with({test::gravity_input(10, Vec3(1, -9.81, 0))}), none);
  UserInput push = test::property_input(K::ApplyImpulse, 10, id, 0);
  push.linear = Vec3(0, 5, 0);
  EXPECT_NE(hash_with({test::property_input(K::SetMass, 10, id, 4.0), push}), hash_with({push}));
  EXPECT_NE(hash_with({test::property_input(K::SetFriction, 1, id, 0.0), test::property_input(K::SetRestitution, 1, id, 1.0)}),
            none);
  EXPECT_EQ(hash_with({test::property_input(K::SetUserData, 10, id, 0, 77)}), none);  // no physics reads it
}

TEST(SimulationSetters, BadValuesAreRefusedNamingTheBodyAndTheField) {
  const Scene s = setter_scene();
  const BodyId id = test::first_dynamic(s);
  BodyId ground = 0;
  for (const Body& b : s.bodies)
    if (b.is_static) ground = b.id;
  Simulation sim(s, SimulationConfig{.territories = 2});
  auto refused = [&](const std::function<void()>& call, const std::vector<std::string>& needles) {
    try {
      call();
      ADD_FAILURE() << "accepted; expected: " << needles.front();
    } catch (const std::invalid_argument& e) {
      std::printf("refused: %s\n", e.what());
      for (const std::string& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  };
  const std::string body = "body " + std::to_string(id);
  refused([&] { sim.set_mass(sim.time_of(5), id, -1.0); }, {body, "mass must be > 0"});
  refused([&] { sim.set_mass(sim.time_of(5), id, 0.0); }, {body, "mass"});
  refused([&] { sim.set_mass(sim.time_of(5), id, std::nan("")); }, {body, "mass"});
  refused([&] { sim.set_mass(sim.time_of(5), id, INFINITY); }, {body, "mass"});
  refused([&] { sim.set_friction(sim.time_of(5), id, -0.1); }, {body, "friction must be >= 0"});
  refused([&] { sim.set_restitution(sim.time_of(5), id, 1.5); }, {body, "restitution must be in [0, 1]"});
  refused([&] { sim.set_restitution(sim.time_of(5), id, -0.5); }, {body, "restitution"});
  refused([&] { sim.set_gravity(sim.time_of(5), Vec3(0, std::nan(""), 0)); }, {"gravity must be finite"});
  refused([&] { sim.set_mass(sim.time_of(5), ground, 2.0); }, {"body " + std::to_string(ground), "static"});
  refused([&] { sim.set_user_data(sim.time_of(5), test::unused_id(s), 1); }, {"no body has that id"});
  EXPECT_TRUE(sim.input_log().empty());  // nothing of a refused input was taken
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  Simulation clean(s, SimulationConfig{.territories = 1});
  EXPECT_TRUE(clean.advance_to(clean.time_of(40)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(clean.state_hash()));
}

// The input log is an input file: read back, given to a fresh run, the same
// hash; and its text reads back to the same inputs, field for field.
TEST(SimulationSetters, InputLogReplaysToTheSameHash) {
  const Scene s = setter_scene();
  const std::vector<UserInput> plan = test::setter_plan(s);
  Simulation sim(s, SimulationConfig{.territories = 4});
  for (const UserInput& in : plan) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-setters-log.json").string();
  sim.write_input_log(path);
  const std::vector<UserInput> log = load_input_file(path);
  std::filesystem::remove(path);
  ASSERT_EQ(log.size(), plan.size());
  for (std::size_t i = 0; i < log.size(); ++i) {
    EXPECT_EQ(log[i].kind, plan[i].kind) << i;
    EXPECT_EQ(log[i].step, plan[i].step) << i;
    EXPECT_EQ(log[i].id, plan[i].id) << i;
    EXPECT_EQ(log[i].value, plan[i].value) << i;
    EXPECT_EQ(log[i].user_data, plan[i].user_data) << i;
    EXPECT_TRUE(log[i].linear == plan[i].linear) << i;
  }
  Simulation replay(s, SimulationConfig{.territories = 2});
  for (const UserInput& in : log) replay.give(in);
  EXPECT_TRUE(replay.advance_to(replay.time_of(kSteps)));
  EXPECT_EQ(hash_hex(replay.state_hash()), hash_hex(sim.state_hash()));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(reference().run.hash));
}

TEST(SimulationSetters, InputFileRefusesBadValuesNamingTheBodyAndTheField) {
  const auto refused = test::expect_input_file_refused;
  refused(R"({"type": "set_mass", "step": 3, "id": 7, "mass": -2})", {"body 7", "'mass'", "> 0"});
  refused(R"({"type": "set_friction", "step": 3, "id": 7, "friction": -1})", {"body 7", "'friction'"});
  refused(R"({"type": "set_restitution", "step": 3, "id": 7, "restitution": 2})", {"body 7", "'restitution'"});
  refused(R"({"type": "set_user_data", "step": 3, "id": 7, "user_data": -5})", {"'user_data'"});
  refused(R"({"type": "set_gravity", "step": 3, "gravity": [0, 1]})", {"'gravity'"});
  refused(R"({"type": "set_mass", "step": 3, "id": 7})", {"'mass'", "missing"});
  const std::vector<UserInput> ok = parse_inputs_json(
      R"({"format": "soda-inputs", "version": 1, "inputs": [{"type": "set_user_data", "step": 1, "id": 2,
          "user_data": 18446744073709551615}, {"type": "set_gravity", "step": 0, "gravity": [0, -1.5, 0]}]})",
      "ok.json");
  ASSERT_EQ(ok.size(), 2u);
  EXPECT_EQ(ok[1].user_data, 18446744073709551615ull);  // sorted by step: the gravity first
  EXPECT_EQ(ok[0].kind, K::SetGravity);
  EXPECT_EQ(ok[0].linear.y(), -1.5);
  // An added body's tag, written and read back; 0 is not written.
  UserInput add;
  add.kind = K::AddBody;
  add.step = 4;
  add.body = test::new_cube(9, Vec3(0, 3, 0));
  add.body.user_data = 0x8000000000000001ull;
  std::vector<UserInput> again = parse_inputs_json(inputs_to_json({add, ok[0], ok[1]}), "again.json");
  ASSERT_EQ(again.size(), 3u);
  EXPECT_EQ(again[0].kind, K::SetGravity);  // step 0
  EXPECT_EQ(again[1].user_data, 18446744073709551615ull);
  EXPECT_EQ(again[2].body.user_data, 0x8000000000000001ull);
  add.body.user_data = 0;
  EXPECT_EQ(inputs_to_json({add}).find("user_data"), std::string::npos);
}

// Saved at step 40 — after the tags, masses, frictions, restitutions and
// the sideways gravity, before the later inputs, which the checkpoint
// queues — and resumed with other territories: the uninterrupted hash.
TEST(SimulationSetters, CheckpointVersion4CarriesEverything) {
  const Scene s = setter_scene();
  Simulation sim(s, SimulationConfig{.territories = 2});
  for (const UserInput& in : test::setter_plan(s)) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(40)));
  const std::string path = (std::filesystem::temp_directory_path() / "soda-setters.ckpt").string();
  EXPECT_EQ(sim.save(path), 40);
  sim.stop();
  const SimulationSnapshot snap = read_checkpoint(path);
  EXPECT_TRUE(snap.state.settings.gravity == Vec3(2.5, -7.0, 0.5));
  Simulation resumed = Simulation::resume(path, SimulationConfig{.territories = 4});
  std::filesystem::remove(path);
  EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
  EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(reference().run.hash));
  SceneReader reader = resumed.add_reader();
  const BodyId id = test::first_dynamic(s);
  std::optional<BodyAt> b = reader.body_at(resumed.time_of(kSteps), id);
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->user_data, test::plan_tag(id));
  EXPECT_EQ(b->friction, 1.2);  // an input the checkpoint queued
  // Versions 1 to 3 cannot say user data: refused by name; a snapshot
  // without the new inputs and tags writes as version 1 or 3 and resumes.
  EXPECT_THROW(encode_checkpoint(snap, 1), CheckpointError);
  try {
    encode_checkpoint(snap, 3);
    ADD_FAILURE() << "version 3 took user data";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 3 cannot hold body"), std::string::npos) << e.what();
  }
}

TEST(SimulationSetters, CheckpointVersion1StillResumes) {
  const Scene s = setter_scene();
  const BodyId id = test::first_dynamic(s);
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.set_velocity(sim.time_of(50), id, Vec3(1, 2, 3));
  EXPECT_TRUE(sim.advance_to(sim.time_of(30)));
  const SimulationSnapshot snap = sim.snapshot();
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const std::vector<std::uint8_t> v1 = encode_checkpoint(snap, 1);
  EXPECT_EQ(checkpoint_header(v1).version, 1u);
  EXPECT_NE(v1, encode_checkpoint(snap));
  Simulation resumed(decode_checkpoint(v1, "v1"), SimulationConfig{.territories = 4});
  EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
  EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(sim.state_hash()));
  // Version 3 (collision filters and compounds, no user data) as well.
  const std::vector<std::uint8_t> v3 = encode_checkpoint(snap, 3);
  EXPECT_EQ(checkpoint_header(v3).version, 3u);
  Simulation resumed3(decode_checkpoint(v3, "v3"), SimulationConfig{.territories = 4});
  EXPECT_TRUE(resumed3.advance_to(resumed3.time_of(kSteps)));
  EXPECT_EQ(hash_hex(resumed3.state_hash()), hash_hex(sim.state_hash()));
  // A version this build does not know is refused by its number.
  std::vector<std::uint8_t> next = v1;
  next[8] = static_cast<std::uint8_t>(kCheckpointVersion + 1);
  const std::string number = "format version " + std::to_string(kCheckpointVersion + 1);
  try {
    decode_checkpoint(next, "next");
    ADD_FAILURE() << number << " accepted";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find(number), std::string::npos) << e.what();
  }
}

// body_at and try_body_at: the frame's pose, the properties of that step
// (an input at boundary s shows from frame s + 1), nullopt for a body not
// in the frame.
TEST(SimulationSetters, BodyAtReadsTheCommittedStep) {
  const Scene s = setter_scene();
  const BodyId id = test::first_dynamic(s);
  Body extra = test::new_cube(test::unused_id(s), Vec3(0, 20, 0));
  extra.user_data = 42;
  Simulation sim(s, SimulationConfig{.territories = 2});
  sim.add_body(sim.time_of(10), extra);
  sim.set_user_data(sim.time_of(20), id, 7);
  sim.set_mass(sim.time_of(20), id, 3.0);
  SceneReader reader = sim.add_reader();
  EXPECT_FALSE(reader.try_body_at(sim.time_of(25), id).has_value());  // not published yet: never waits
  EXPECT_TRUE(sim.advance_to(sim.time_of(30)));
  std::optional<BodyAt> before = reader.body_at(sim.time_of(20), id);
  ASSERT_TRUE(before.has_value());
  EXPECT_EQ(before->user_data, 0u);
  EXPECT_EQ(before->mass, 1.0);
  std::optional<BodyAt> after = reader.try_body_at(sim.time_of(21), id);
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->user_data, 7u);
  EXPECT_EQ(after->mass, 3.0);
  EXPECT_FALSE(reader.body_at(sim.time_of(22), test::unused_id(s) + 5).has_value());
  std::optional<BodyAt> added = reader.body_at(sim.time_of(25), extra.id);
  ASSERT_TRUE(added.has_value());
  EXPECT_EQ(added->user_data, 42u);
  std::optional<SceneFrame> frame = reader.read_at(sim.time_of(30));
  ASSERT_TRUE(frame.has_value());
  const ScenePose* pose = frame->find(id);
  ASSERT_NE(pose, nullptr);
  std::optional<BodyAt> again = reader.body_at(sim.time_of(30), id);
  ASSERT_TRUE(again.has_value());
  EXPECT_TRUE(test::same_bits(again->pose, *pose));
  EXPECT_EQ(reader.properties(30, id)->user_data, 7u);
}

}  // namespace
}  // namespace soda
