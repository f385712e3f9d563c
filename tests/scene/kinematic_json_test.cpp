// Kinematic bodies in scene files and scene validation (docs/scene-format.md,
// "Kinematic bodies"): the path's interpolation, the round trip, and one test
// per bad kinematic body. Each error names the source, the body (index and
// id) and the field.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "scene_test_util.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

std::string scene_with(const std::string& body) {
  return R"({"format": "soda-scene", "version": 1, "name": "t",
    "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
      {"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
       "position": [0, 3, 0]},
      )" + body + "]}";
}

using test::scene_error_of;

const char* kPallet =
    R"({"id": 3, "type": "kinematic", "shape": {"type": "box", "half_extents": [1, 0.1, 1]},
        "path": {"loop": true, "keys": [
          {"time": 0, "position": [-2, 1, 0]},
          {"time": 2, "position": [2, 1, 0], "orientation": [0, 0.7071067811865476, 0, 0.7071067811865476]},
          {"time": 4, "position": [-2, 1, 0]}]}})";

TEST(KinematicJson, APathParsesAndRoundTrips) {
  const Scene s = parse_scene_json(scene_with(kPallet), "good.json");
  const Body& k = s.bodies[2];
  EXPECT_TRUE(k.kinematic);
  EXPECT_TRUE(k.is_static);
  ASSERT_EQ(k.path.keys.size(), 3u);
  EXPECT_TRUE(k.path.loop);
  EXPECT_EQ(k.position, Vec3(-2, 1, 0));  // no position: the path's start
  const Scene again = parse_scene_json(scene_to_json(s), "again.json");
  const Body& k2 = again.bodies[2];
  EXPECT_TRUE(k2.kinematic);
  ASSERT_EQ(k2.path.keys.size(), 3u);
  EXPECT_TRUE(k2.path.loop);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(k2.path.keys[i].time, k.path.keys[i].time);
    EXPECT_EQ(k2.path.keys[i].position, k.path.keys[i].position);
    EXPECT_EQ(k2.path.keys[i].orientation.coeffs(), k.path.keys[i].orientation.coeffs());
  }
  EXPECT_EQ(scene_to_json(again), scene_to_json(s));
}

TEST(KinematicJson, PosesInterpolateBetweenKeysAndLoop) {
  const Scene s = parse_scene_json(scene_with(kPallet), "good.json");
  const Body& k = s.bodies[2];
  EXPECT_EQ(kinematic_pose(k, 0.0).position, Vec3(-2, 1, 0));
  EXPECT_EQ(kinematic_pose(k, 1.0).position, Vec3(0, 1, 0));
  EXPECT_EQ(kinematic_pose(k, 2.0).position, Vec3(2, 1, 0));
  EXPECT_EQ(kinematic_pose(k, 3.0).position, Vec3(0, 1, 0));
  EXPECT_EQ(kinematic_pose(k, 5.0).position, Vec3(0, 1, 0));  // looped: as at 1 s
  // Half way to a quarter turn about y: an eighth of a turn (nlerp of two
  // keys is the slerp at the middle).
  const Quat q = kinematic_pose(k, 1.0).orientation;
  EXPECT_NEAR(q.angularDistance(Quat(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitY()))), 0.0, 1e-12);
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  // Without loop: held at the ends.
  Body once = k;
  once.path.loop = false;
  EXPECT_EQ(kinematic_pose(once, 9.0).position, Vec3(-2, 1, 0));
  once.path.keys.pop_back();
  EXPECT_EQ(kinematic_pose(once, 9.0).position, Vec3(2, 1, 0));
  // Without a path: where the body is.
  Body still = k;
  still.path.keys.clear();
  still.position = Vec3(1, 2, 3);
  EXPECT_EQ(kinematic_pose(still, 7.0).position, Vec3(1, 2, 3));
}

TEST(KinematicJson, BadKinematicBodiesAreRefusedNamingTheField) {
  const std::string body = "body #2 (id 3)";
  const auto refused = [&](const std::string& b, const std::string& field, const std::string& what) {
    const std::string e = scene_error_of(scene_with(b));
    EXPECT_NE(e.find(body), std::string::npos) << e;
    EXPECT_NE(e.find("field '" + field + "'"), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  const std::string shape = R"("shape": {"type": "box", "half_extents": [1, 0.1, 1]})";
  refused(R"({"id": 3, "type": "kinematic", "mass": 2, )" + shape + "}", "mass", "no mass");
  refused(R"({"id": 3, "type": "kinematic", "position": [0, 1, 0], "linear_velocity": [1, 0, 0], )" + shape + "}",
          "linear_velocity", "come from its path");
  refused(R"({"id": 3, "type": "static", "position": [0, 1, 0], "path": {"keys": [{"time": 0, "position": [0, 1, 0]}]}, )" +
              shape + "}",
          "path", "only kinematic bodies");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"keys": [{"time": 1, "position": [0, 1, 0]}, {"time": 1, "position": [1, 1, 0]}]}})",
          "path.keys[1].time", "later than the key before");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"keys": [{"time": -1, "position": [0, 1, 0]}]}})",
          "path.keys[0].time", ">= 0");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"loop": true, "keys": [{"time": 1, "position": [0, 1, 0]}, {"time": 2, "position": [1, 1, 0]}]}})",
          "path.keys[0].time", "starts at time 0");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"loop": true, "keys": [{"time": 0, "position": [0, 1, 0]}]}})",
          "path.loop", "at least two keys");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"keys": [{"time": 0, "position": [0, 1, 0], "orientation": [0, 0, 0, 0]}]}})",
          "path.keys[0].orientation", "non-zero");
  refused(R"({"id": 3, "type": "kinematic", )" + shape +
              R"(, "path": {"keys": [{"time": 0, "position": [0, 1]}]}})",
          "path.keys[0].position", "3 numbers");
  refused(R"({"id": 3, "type": "kinematic", )" + shape + R"(, "path": {"keys": [{"time": 0}]}})",
          "path.keys[0].position", "missing");
  refused(R"({"id": 3, "type": "kinematic", "asleep": true, "position": [0, 1, 0], )" + shape + "}", "asleep",
          "kinematic body cannot be asleep");
}

// A NaN in a path built in code (JSON has none) is refused by validate_scene.
TEST(KinematicJson, ValidationRefusesANonFiniteKey) {
  Scene s = make_scene("conveyor", SceneParams{12, 1, false});
  validate_scene(s, "conveyor");
  Body& pallet = s.bodies[1];
  ASSERT_TRUE(pallet.kinematic);
  pallet.path.keys[1].position.y() = std::nan("");
  try {
    validate_scene(s, "conveyor");
    ADD_FAILURE() << "a NaN path key was accepted";
  } catch (const SceneError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("(id 1)"), std::string::npos) << m;
    EXPECT_NE(m.find("path.keys[1].position"), std::string::npos) << m;
  }
}

TEST(KinematicJson, AJointToAKinematicBodyIsRefused) {
  Scene s = make_scene("conveyor", SceneParams{12, 1, false});
  Joint j;
  j.id = 1;
  j.kind = JointKind::PointToPoint;
  j.body_a = 1;   // a pallet
  j.body_b = 10;  // a box
  s.joints.push_back(j);
  try {
    validate_scene(s, "conveyor");
    ADD_FAILURE() << "a joint to a kinematic body was accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("kinematic"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace soda
