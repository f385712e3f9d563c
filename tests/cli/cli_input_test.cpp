// `soda run --inputs FILE` (docs/inputs.md) and the small things users trip
// over (issue 14): the input script replays through the embedding API's
// calls to the API's hash, for every territory count; negative seeds, steps
// and bodies outside the precision envelope are bad input (exit 2) naming
// the option, or the body and the field.
#include <algorithm>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "cli/cli_test_util.h"
#include "soda/runtime/simulation.h"

namespace {

using namespace soda_cli_test;

const bool kDoubleBuild = std::string(SODA_CLI_PATH).ends_with("-double");

TEST_F(CliTest, NegativeSeedIsBadInput) {
  for (const char* option : {"--seed -1", "--shuffle-seed -3"}) {
    const Outcome o = run_cli(std::string("run --scene falling-cubes --n 10 --steps 1 ") + option);
    EXPECT_EQ(o.exit_code, 2) << option << "\n" << o.output;
    EXPECT_NE(o.output.find("must be >= 0"), std::string::npos) << o.output;
    EXPECT_EQ(o.output.find("18446744073709551615"), std::string::npos) << o.output;
  }
}

TEST_F(CliTest, StepThatRoundsAwayIsBadInput) {
  const Outcome o = run_cli("run --scene falling-cubes --n 10 --steps 1 --dt 1e-300");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_NE(o.output.find("falling-cubes with --dt 1e-300: settings: field 'dt'"), std::string::npos) << o.output;
}

TEST_F(CliTest, BodyOutsideThePrecisionEnvelopeIsBadInput) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 1},
      "position": [1e30, 2, 0], "linear_velocity": [100, 0, 0]})"), "body #1 (id 3): field 'position'");
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1e300, "shape": {"type": "sphere", "radius": 1},
      "position": [0, 2, 0]})"), "body #1 (id 3): field 'mass'");
  // 1e-40 kg: a subnormal float (the float build stopped at step 1 on the
  // watchdog); a double world simulates it.
  const std::string light = bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1e-40,
      "shape": {"type": "sphere", "radius": 1}, "position": [0, 2, 0]})");
  if (kDoubleBuild) {
    const Outcome o = run_cli("run --scene " + light + " --steps 2");
    EXPECT_EQ(o.exit_code, 0) << o.output;
  } else {
    expect_bad_input(light, "body #1 (id 3): field 'mass'");
  }
}

// The scene and inputs of tests/runtime/simulation_input_test.cpp: a cube
// added, a body pushed, the new cube kicked, the pushed body removed.
class CliInputs : public CliTest {
 protected:
  static constexpr int kSteps = 160;
  const soda::Scene scene_ = soda::make_scene("cube-pile", {120, 1, false});
  soda::BodyId pushed_ = 0, added_ = 0;
  std::string run_ = "run --scene cube-pile --n 120 --seed 1 --steps 160 --log-level warn ";

  void SetUp() override {
    CliTest::SetUp();
    for (const soda::Body& b : scene_.bodies) {
      if (!b.is_static && pushed_ == 0) pushed_ = b.id;
      added_ = std::max(added_, b.id + 1);
    }
  }
  soda::Body cube() const {
    soda::Body b;
    b.id = added_;
    b.shape = soda::Shape::box(soda::Vec3::Constant(0.5));
    b.mass = 1.0;
    b.position = soda::Vec3(0, 12, 0);
    b.linear_velocity = soda::Vec3(0, -2, 0);
    return b;
  }
  // The same inputs as a file, in an order of its own (the file need not be
  // sorted by step).
  std::string inputs_file() {
    const std::string p = std::to_string(pushed_), a = std::to_string(added_);
    return write("inputs.json", R"({"format": "soda-inputs", "version": 1, "inputs": [
      {"type": "remove_body", "step": 120, "id": )" + p + R"(},
      {"type": "add_body", "step": 40, "body": {"id": )" + a + R"(, "type": "dynamic", "mass": 1,
        "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]}, "position": [0, 12, 0],
        "linear_velocity": [0, -2, 0]}},
      {"type": "set_velocity", "step": 60, "id": )" + p + R"(, "linear_velocity": [3, 4, 0],
        "angular_velocity": [0, 1, 0]},
      {"type": "apply_impulse", "step": 70, "id": )" + a + R"(, "impulse": [-2, 0, 1]},
      {"type": "set_mass", "step": 80, "id": )" + a + R"(, "mass": 3.5},
      {"type": "set_gravity", "step": 90, "gravity": [1, -9.81, 0]},
      {"type": "set_friction", "step": 95, "id": )" + a + R"(, "friction": 0.1},
      {"type": "set_restitution", "step": 95, "id": )" + a + R"(, "restitution": 0.5},
      {"type": "set_user_data", "step": 100, "id": )" + a + R"(, "user_data": 12345678901234567890}
    ]})");
  }
  // The API: the calls an embedding application makes.
  std::string api_hash() const {
    soda::Simulation sim(scene_);
    sim.add_body(sim.time_of(40), cube());
    sim.set_velocity(sim.time_of(60), pushed_, soda::Vec3(3, 4, 0), soda::Vec3(0, 1, 0));
    sim.apply_impulse(sim.time_of(70), added_, soda::Vec3(-2, 0, 1));
    sim.set_mass(sim.time_of(80), added_, 3.5);
    sim.set_gravity(sim.time_of(90), soda::Vec3(1, -9.81, 0));
    sim.set_friction(sim.time_of(95), added_, 0.1);
    sim.set_restitution(sim.time_of(95), added_, 0.5);
    sim.set_user_data(sim.time_of(100), added_, 12345678901234567890ull);
    sim.remove_body(sim.time_of(120), pushed_);
    EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
    return soda::hash_hex(sim.state_hash());
  }
};

TEST_F(CliInputs, ReplayGivesTheApiHashForEveryTerritoryCount) {
  const std::string api = api_hash();
  const std::string file = inputs_file();
  const Outcome none = run_cli(run_);
  ASSERT_EQ(none.exit_code, 0) << none.output;
  std::printf("API %s; no inputs %s\n", api.c_str(), hash_of(none).c_str());
  EXPECT_NE(hash_of(none), api);  // the inputs do something
  for (const char* args : {"--territories 1", "--territories 4", "--territories 4 --threads 1",
                           "--territories 4 --anticipation 8", "--territories 3 --partition grid:3x1x1"}) {
    const Outcome o = run_cli(run_ + "--inputs " + file + " " + args);
    ASSERT_EQ(o.exit_code, 0) << args << "\n" << o.output;
    std::printf("--inputs %s: state_hash %s\n", args, hash_of(o).c_str());
    EXPECT_EQ(hash_of(o), api) << args << "\n" << o.output;
  }
}

TEST_F(CliInputs, BadInputsNameTheFileTheEntryAndTheField) {
  const auto refused = [&](const std::string& entries, const std::string& args, const std::string& needle) {
    const std::string file =
        write("bad_inputs.json", R"({"format": "soda-inputs", "version": 1, "inputs": [)" + entries + "]}");
    const Outcome o = run_cli(run_ + "--inputs " + file + " " + args);
    EXPECT_EQ(o.exit_code, 2) << o.output;
    EXPECT_NE(o.output.find(file), std::string::npos) << o.output;
    EXPECT_NE(o.output.find(needle), std::string::npos) << o.output;
  };
  refused(R"({"type": "set_velocity", "step": 5, "id": 99999, "linear_velocity": [1, 0, 0]})", "",
          "input #0 (set_velocity at step 5): set the velocity of body 99999 at step 5: no body has that id");
  refused(R"({"type": "apply_impulse", "step": 5, "id": 1, "impulse": [1, 0]})", "",
          "input #0 (apply_impulse at step 5): field 'impulse'");
  refused(R"({"type": "add_body", "step": 5, "body": {"id": 1, "type": "dynamic", "mass": 1,
      "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 30, 0]}})", "--territories 2", "is in use");
  refused(R"({"type": "add_body", "step": 5, "body": {"id": 5000, "type": "dynamic", "mass": 1e-300,
      "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 30, 0]}})", "", "field 'mass'");
  refused(R"({"type": "set_mass", "step": 5, "id": 1, "mass": -1})", "",
          "input #0 (set_mass at step 5): body 1: field 'mass': mass must be > 0 and finite, got -1");
  refused(R"({"type": "set_restitution", "step": 5, "id": 1, "restitution": 1.5})", "--territories 2",
          "body 1: field 'restitution': restitution must be in [0, 1]");
  refused(R"({"type": "set_kinematic_target", "step": 5, "id": 1, "position": [0, 2, 0]})", "--territories 2",
          "set the kinematic target of body 1 at step 5: body 1 is not kinematic");
  refused(R"({"type": "set_pose", "step": 5, "id": 99999, "position": [0, 2, 0]})", "",
          "set the pose of body 99999 at step 5: no body has that id");
  refused(R"({"type": "set_pose", "step": 5, "id": 1, "position": [0, 2]})", "",
          "input #0 (set_pose at step 5): body 1: field 'position'");
  refused(R"({"type": "set_pose", "step": 5, "id": 1, "position": [0, 2, 0], "orientation": [0, 0, 0, 0]})", "",
          "body 1: field 'position/orientation': orientation must be a non-zero quaternion");
  refused(R"({"type": "set_friction", "step": 5, "id": 0, "friction": 0.2})", "",
          "set the friction of body 0 at step 5: the body is static");
  const Outcome stock = run_cli(run_ + "--inputs " + inputs_file() + " --world stock");
  EXPECT_EQ(stock.exit_code, 2) << stock.output;
  EXPECT_NE(stock.output.find("--inputs runs the canonical world only"), std::string::npos) << stock.output;
  const Outcome missing = run_cli(run_ + "--inputs " + (dir_ / "none.json").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("cannot open input file"), std::string::npos) << missing.output;
}

}  // namespace

namespace {

using namespace soda_cli_test;

// Triangle meshes and heightfields (docs/scene-format.md, "Triangle meshes
// and heightfields"): a dynamic mesh, a degenerate triangle, an index out of
// range, a heightfield of the wrong size and an OBJ file that is not there
// are bad input (exit 2) naming the body and the field; the shipped bowl
// (tests/data/bowl.json and its bowl.obj) runs, on 2 territories to the
// one territory's hash.
TEST_F(CliTest, BadMeshesAndHeightfieldsAreBadInput) {
  expect_bad_input(bad_scene(R"({"id": 3, "type": "dynamic", "mass": 1, "position": [0, 2, 0], "shape":
      {"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [[0, 2, 1]]}})"),
                   "body #1 (id 3): field 'shape.type': a dynamic body cannot be a triangle_mesh");
  expect_bad_input(bad_scene(R"({"id": 3, "type": "static", "position": [0, 2, 0], "shape":
      {"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], "indices": [[0, 2, 1]]}})"),
                   "body #1 (id 3): field 'shape.indices[0]': degenerate triangle");
  expect_bad_input(bad_scene(R"({"id": 3, "type": "static", "position": [0, 2, 0], "shape":
      {"type": "triangle_mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [[0, 2, 9]]}})"),
                   "body #1 (id 3): field 'shape.indices[0]': vertex index 9 out of range");
  expect_bad_input(bad_scene(R"({"id": 3, "type": "static", "position": [0, 2, 0], "shape":
      {"type": "heightfield", "columns": 3, "rows": 2, "heights": [0, 1, 2, 3]}})"),
                   "body #1 (id 3): field 'shape.heights': holds 4 heights, columns * rows = 6");
  expect_bad_input(bad_scene(R"({"id": 3, "type": "static", "position": [0, 2, 0], "shape":
      {"type": "triangle_mesh", "file": "nowhere.obj"}})"),
                   "body #1 (id 3): field 'shape.file': ");
}

TEST_F(CliTest, ShippedBowlMeshRunsAlikeOnTwoTerritories) {
  const std::string bowl = std::string(SODA_TEST_DATA) + "/bowl.json";
  const Outcome one = run_cli("run --scene " + bowl + " --steps 120");
  const Outcome two = run_cli("run --scene " + bowl + " --steps 120 --territories 2");
  ASSERT_EQ(one.exit_code, 0) << one.output;
  ASSERT_EQ(two.exit_code, 0) << two.output;
  EXPECT_FALSE(hash_of(one).empty()) << one.output;
  EXPECT_EQ(hash_of(one), hash_of(two)) << two.output;
}

}  // namespace
