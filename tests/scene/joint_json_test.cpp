// Joints in scene files and scene validation (docs/scene-format.md,
// "Joints"): round trip, and one test per bad joint. Each error names the
// source, the joint (index and id) and the field.
#include <cmath>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "scene_test_util.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

std::string scene_with_joint(const std::string& joint) {
  return R"({"format": "soda-scene", "version": 1, "name": "t",
    "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]}, "position": [0, -0.5, 0]},
      {"id": 1, "type": "static", "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.1]}, "position": [0, 5, 0]},
      {"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.1, 0.1]},
       "position": [0.5, 5, 0]},
      {"id": 8, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.1, 0.1]},
       "position": [1.5, 5, 0]}
    ],
    "joints": [)" + joint + "]}";
}

using test::scene_error_of;

const char* kHinge =
    R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "frame_a": {"position": [0.5, 0, 0]},
        "frame_b": {"position": [-0.5, 0, 0], "orientation": [0, 0, 0, 1]}, "limit": [-1, 1],
        "motor": {"velocity": 2, "max_impulse": 0.5}, "breaking_impulse": 100})";

TEST(JointJson, AGoodJointParses) {
  const Scene s = parse_scene_json(scene_with_joint(kHinge), "good.json");
  ASSERT_EQ(s.joints.size(), 1u);
  const Joint& j = s.joints[0];
  EXPECT_EQ(j.id, 5u);
  EXPECT_EQ(j.kind, JointKind::Hinge);
  EXPECT_EQ(j.body_a, 7u);
  EXPECT_EQ(j.body_b, 8u);
  EXPECT_EQ(j.frame_a.position, Vec3(0.5, 0, 0));
  EXPECT_TRUE(j.limited);
  EXPECT_EQ(j.upper, 1.0);
  EXPECT_TRUE(j.motor);
  EXPECT_EQ(j.motor_velocity, 2.0);
  EXPECT_EQ(j.breaking_impulse, 100.0);
  EXPECT_FALSE(j.collide_connected);  // the default
}

TEST(JointJson, RegistryJointScenesRoundTrip) {
  for (const char* name : {"pendulums", "chain-bridge", "ragdolls", "hanging-chain", "heavy-chain", "motor-hinge"}) {
    const Scene scene = make_scene(name, SceneParams{3, 7, false});
    ASSERT_FALSE(scene.joints.empty()) << name;
    const std::string text = scene_to_json(scene);
    const Scene back = parse_scene_json(text, name);
    EXPECT_EQ(back.joints.size(), scene.joints.size());
    EXPECT_EQ(scene_to_json(back), text) << name;
  }
}

TEST(JointJson, EveryKindRoundTrips) {
  Scene scene = parse_scene_json(scene_with_joint(kHinge), "good.json");
  const Joint hinge = scene.joints[0];
  for (JointKind kind : {JointKind::PointToPoint, JointKind::Slider, JointKind::ConeTwist, JointKind::Fixed,
                         JointKind::Spring6Dof}) {
    Joint j = hinge;
    j.kind = kind;
    j.id = static_cast<JointId>(scene.joints.size() + 10);
    j.limited = kind == JointKind::Slider;
    j.lower = -0.5, j.upper = 0.5;
    j.motor = kind == JointKind::Slider;
    j.stiffness[1] = 50, j.damping[1] = 1, j.axis_lower[1] = -1, j.axis_upper[1] = 1;
    j.motor_max_forces[3] = 2, j.motor_velocities[3] = 1;
    j.swing_span1 = 0.5, j.swing_span2 = 0.25, j.twist_span = 0.1;
    scene.joints.push_back(j);
  }
  validate_scene(scene, "kinds");
  const std::string text = scene_to_json(scene);
  EXPECT_EQ(scene_to_json(parse_scene_json(text, "kinds")), text);
}

TEST(JointJson, SceneWithoutJointsIsWrittenAsBefore) {
  const Scene scene = make_scene("falling-cubes", SceneParams{5, 1, false});
  EXPECT_EQ(scene_to_json(scene).find("joints"), std::string::npos);
}

struct BadJoint {
  const char* joint;
  const char* field;
  const char* what;
};

TEST(JointJson, BadJointsAreRefusedByNameAndField) {
  const BadJoint cases[] = {
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 99})", "field 'body_b'", "no body with id 99"},
      {R"({"id": 5, "type": "hinge", "body_a": 98, "body_b": 7})", "field 'body_a'", "no body with id 98"},
      {R"({"id": 5, "type": "hinge", "body_a": 0, "body_b": 1})", "field 'body_b'", "static"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 7})", "field 'body_b'", "to itself"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "limit": [1, -1]})", "field 'limit'", "above upper"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "limit": [-4, 1]})", "field 'limit'", "[-3.14"},
      {R"({"id": 5, "type": "cone-twist", "body_a": 7, "body_b": 8, "spans": [1, -1, 0]})", "field 'spans'",
       "[0, pi]"},
      {R"({"id": 5, "type": "spring-6dof", "body_a": 7, "body_b": 8, "axes": {"stiffness": [0, -1, 0, 0, 0, 0]}})",
       "field 'axes.stiffness[1]'", ">= 0"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "breaking_impulse": 0})", "field 'breaking_impulse'",
       "> 0"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "motor": {"velocity": 1, "max_impulse": -1}})",
       "field 'motor.max_impulse'", ">= 0"},
      {R"({"id": 5, "type": "weld", "body_a": 7, "body_b": 8})", "field 'type'", "unknown joint type 'weld'"},
      {R"({"id": 5, "type": "fixed", "body_a": 7, "body_b": 8, "limit": [0, 1]})", "field 'limit'",
       "unknown field for a fixed joint"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "frame_a": {"position": [0, 0]}})",
       "field 'frame_a.position'", "3 numbers"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8, "frame_b": {"orientation": [0, 0, 0, 0]}})",
       "field 'frame_b.orientation'", "non-zero"},
      {R"({"id": 5, "type": "hinge", "body_a": 7, "body_b": 8}, {"id": 5, "type": "fixed", "body_a": 7, "body_b": 1})",
       "joint #1 (id 5): field 'id'", "duplicate joint id"},
  };
  for (const BadJoint& c : cases) {
    const std::string message = scene_error_of(scene_with_joint(c.joint));
    EXPECT_NE(message.find("bad.json: joint #"), std::string::npos) << message;
    EXPECT_NE(message.find("(id 5)"), std::string::npos) << message;
    EXPECT_NE(message.find(c.field), std::string::npos) << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << message;
  }
}

TEST(JointJson, NonFiniteValuesAreRefused) {
  // JSON cannot hold NaN: a scene built in code can.
  Scene scene = parse_scene_json(scene_with_joint(kHinge), "good.json");
  scene.joints[0].frame_a.position.y() = std::numeric_limits<double>::quiet_NaN();
  try {
    validate_scene(scene, "code");
    ADD_FAILURE() << "NaN accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("code: joint #0 (id 5): field 'frame_a.position'"), std::string::npos)
        << e.what();
  }
  scene = parse_scene_json(scene_with_joint(kHinge), "good.json");
  scene.joints[0].motor_velocity = std::numeric_limits<double>::infinity();
  EXPECT_THROW(validate_scene(scene, "code"), SceneError);
}

}  // namespace
}  // namespace soda
