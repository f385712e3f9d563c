// Scene files: round trip, and one test per bad-input case. Each error must
// name the source, the body and the field.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "scene_test_util.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

// A valid two-body scene; tests replace one fragment to make it bad.
std::string scene_text(const std::string& dynamic_body) {
  return R"({"format": "soda-scene", "version": 1, "name": "t",
    "bodies": [
      {"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]},
       "position": [0, -0.5, 0]},
      )" + dynamic_body + R"(
    ]})";
}

const std::string kGoodCube =
    R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
        "position": [0, 2, 0]})";

using test::scene_error_of;

TEST(SceneJson, GoodSceneParses) {
  const Scene s = parse_scene_json(scene_text(kGoodCube), "good.json");
  ASSERT_EQ(s.bodies.size(), 2u);
  EXPECT_EQ(s.bodies[1].id, 7u);
  EXPECT_FALSE(s.bodies[1].is_static);
  EXPECT_TRUE(s.bodies[0].is_static);
  EXPECT_DOUBLE_EQ(s.bodies[1].friction, 0.5);  // default
}

TEST(SceneJson, RoundTripIsBitExact) {
  const Scene a = make_scene("falling-cubes", SceneParams{200, 42, true});
  const Scene b = parse_scene_json(scene_to_json(a), "roundtrip");
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  EXPECT_EQ(a.settings.dt, b.settings.dt);
  for (std::size_t i = 0; i < a.bodies.size(); ++i) {
    const Body &x = a.bodies[i], &y = b.bodies[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.is_static, y.is_static);
    EXPECT_EQ(x.position, y.position);
    EXPECT_EQ(x.orientation.coeffs(), y.orientation.coeffs());
    EXPECT_EQ(x.shape.half_extents, y.shape.half_extents);
    EXPECT_EQ(x.mass, y.mass);
  }
}

TEST(SceneJson, AllShapesRoundTrip) {
  Scene s;
  s.name = "shapes";
  auto add = [&](Shape shape) {
    Body b;
    b.id = static_cast<BodyId>(s.bodies.size());
    b.shape = std::move(shape);
    b.position = Vec3(3.0 * b.id, 1, 0);
    s.bodies.push_back(b);
  };
  add(Shape::box(Vec3(0.5, 0.25, 0.5)));
  add(Shape::sphere(0.3));
  add(Shape::capsule(0.2, 0.8));
  add(Shape::cylinder(Vec3(0.3, 0.5, 0.3)));
  add(Shape::convex_hull({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}));
  const Scene r = parse_scene_json(scene_to_json(s), "shapes");
  ASSERT_EQ(r.bodies.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(r.bodies[i].shape.kind, s.bodies[i].shape.kind);
  EXPECT_EQ(r.bodies[2].shape.height, 0.8);
  EXPECT_EQ(r.bodies[4].shape.points.size(), 4u);
}

TEST(SceneErrors, NanIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
          "position": [NaN, 2, 0]})"));
  EXPECT_NE(e.find("bad.json: body #1 (id 7): field 'position[0]'"), std::string::npos) << e;
  EXPECT_NE(e.find("NaN"), std::string::npos) << e;
}

TEST(SceneErrors, InfiniteNumberIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
          "position": [0, 1e999, 0]})"));
  EXPECT_NE(e.find("bad.json: body #1 (id 7): field 'position[1]'"), std::string::npos) << e;
  EXPECT_NE(e.find("finite"), std::string::npos) << e;
}

TEST(SceneErrors, NanHintOnlyWhereTheTextHasNanOrInfinity) {
  const std::string hint = "JSON has no NaN or Infinity";
  for (const char* token : {"NaN", "-Infinity", "Infinity", "nan", "inf", "-inf"}) {
    const std::string e = scene_error_of(scene_text(
        std::string(R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, )") + token + "]}"));
    EXPECT_NE(e.find(hint), std::string::npos) << token << ": " << e;
  }
  for (const std::string& text : {std::string(""), std::string("   "), std::string(R"({"format": )"),
                                  std::string(R"({"format": "soda-scene",, "version": 1})"),
                                  std::string(R"({"format": nul})"), std::string(R"({"format": 'x'})")}) {
    const std::string e = scene_error_of(text);
    EXPECT_EQ(e.find(hint), std::string::npos) << "'" << text << "': " << e;
    EXPECT_NE(e.find("not valid JSON"), std::string::npos) << e;
  }
}

TEST(SceneErrors, DirectoryIsNotAScene) {
  const std::string dir = std::filesystem::temp_directory_path().string();
  try {
    load_scene_file(dir);
    FAIL() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + ": is a directory"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("NaN"), std::string::npos) << e.what();
  }
}

TEST(SceneErrors, BodiesAreStreamedWhereverTheyAreInTheFile) {
  // Exported files put "bodies" first (keys sorted); hand-written ones last.
  const Scene a = parse_scene_json(R"({"bodies": [{"id": 1, "type": "dynamic", "mass": 2,
      "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 2, 0]}], "format": "soda-scene",
      "settings": {"dt": 0.01}, "version": 1})", "first.json");
  ASSERT_EQ(a.bodies.size(), 1u);
  EXPECT_EQ(a.bodies[0].mass, 2.0);
  EXPECT_EQ(a.settings.dt, 0.01);
  const std::string twice = scene_error_of(R"({"format": "soda-scene", "version": 1, "bodies": [], "bodies": []})");
  EXPECT_NE(twice.find("field 'bodies': given twice"), std::string::npos) << twice;
  const std::string not_array = scene_error_of(R"({"format": "soda-scene", "version": 1, "bodies": {}})");
  EXPECT_NE(not_array.find("field 'bodies': must be an array"), std::string::npos) << not_array;
  const std::string top = scene_error_of(R"([1, 2])");
  EXPECT_NE(top.find("(top level)"), std::string::npos) << top;
  const std::string body = scene_error_of(R"({"format": "soda-scene", "version": 1, "bodies": [3]})");
  EXPECT_NE(body.find("body #0: field '(body)': must be an object"), std::string::npos) << body;
}

TEST(SceneErrors, ZeroMassDynamicIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 0, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("'mass'"), std::string::npos) << e;
}

TEST(SceneErrors, NegativeMassDynamicIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": -2, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'mass'"), std::string::npos) << e;
  EXPECT_NE(e.find("> 0"), std::string::npos) << e;
}

TEST(SceneErrors, ZeroExtentIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0, 0.5]},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("'shape.half_extents'"), std::string::npos) << e;
}

TEST(SceneErrors, NegativeRadiusIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "capsule", "radius": -0.1, "height": 1},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'shape.radius'"), std::string::npos) << e;
}

TEST(SceneErrors, UnknownShapeIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "torus", "radius": 1},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown shape 'torus'"), std::string::npos) << e;
}

TEST(SceneErrors, DuplicateIdIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 0, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 0)"), std::string::npos) << e;
  EXPECT_NE(e.find("duplicate id"), std::string::npos) << e;
}

TEST(SceneErrors, IdOutOfRangeIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 2147483648, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'id'"), std::string::npos) << e;
}

TEST(SceneErrors, MissingFieldIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5}})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("'position': missing"), std::string::npos) << e;
}

TEST(SceneErrors, MissingMassOnDynamicIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'mass': missing"), std::string::npos) << e;
}

TEST(SceneErrors, MistypedFieldIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": "heavy", "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'mass': must be a number, got string"), std::string::npos) << e;
}

TEST(SceneErrors, WrongArrayLengthIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2]})"));
  EXPECT_NE(e.find("'position': must be an array of 3 numbers"), std::string::npos) << e;
}

TEST(SceneErrors, UnknownFieldIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "fricton": 0.3, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("'fricton': unknown field"), std::string::npos) << e;
}

// Collision filters (docs/scene-format.md, "Collision filtering"): read,
// written only where not the default, and 32-bit integers or an error
// naming the body and the field.
TEST(SceneJson, CollisionFilterParsesAndRoundTrips) {
  const Scene s = parse_scene_json(
      scene_text(R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
                     "position": [0, 2, 0], "collision_group": 4, "collision_mask": 4294967291})"),
      "filter.json");
  EXPECT_EQ(s.bodies[0].collision_group, kDefaultCollisionGroup);
  EXPECT_EQ(s.bodies[0].collision_mask, kAllCollisionGroups);
  EXPECT_EQ(s.bodies[1].collision_group, 4u);
  EXPECT_EQ(s.bodies[1].collision_mask, 0xfffffffbu);
  const std::string text = scene_to_json(s);
  EXPECT_EQ(text.find("collision_group"), text.rfind("collision_group")) << "written once, for body 7 only";
  const Scene back = parse_scene_json(text, "roundtrip");
  EXPECT_EQ(back.bodies[1].collision_group, 4u);
  EXPECT_EQ(back.bodies[1].collision_mask, 0xfffffffbu);
  EXPECT_EQ(back.bodies[0].collision_mask, kAllCollisionGroups);
  EXPECT_EQ(scene_to_json(make_scene("falling-cubes", SceneParams{20, 1, true})).find("collision_"), std::string::npos);
}

TEST(SceneErrors, BadCollisionFilterIsRejected) {
  const std::string body = R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
                               "position": [0, 2, 0], )";
  for (const auto& [field, value, why] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"collision_group", "-1", "must be an integer in [0, 2^32)"},
           {"collision_mask", "4294967296", "must be an integer in [0, 2^32)"},
           {"collision_mask", "1.5", "must be an integer in [0, 2^32), got number"},
           {"collision_group", "\"all\"", "must be an integer in [0, 2^32), got string"}}) {
    const std::string e = scene_error_of(scene_text(body + "\"" + field + "\": " + value + "}"));
    EXPECT_NE(e.find("bad.json"), std::string::npos) << e;
    EXPECT_NE(e.find("(id 7)"), std::string::npos) << e;
    EXPECT_NE(e.find("'" + field + "': " + why), std::string::npos) << e;
  }
}

// Sensors: "sensor": true parses, round trips and is written only when
// true; anything but a boolean is an error naming the body and the field.
TEST(SceneJson, SensorParsesAndRoundTrips) {
  const Scene s = parse_scene_json(
      scene_text(R"({"id": 7, "type": "static", "shape": {"type": "box", "half_extents": [2, 1, 2]},
                     "position": [0, 2, 0], "sensor": true})"),
      "sensor.json");
  EXPECT_FALSE(s.bodies[0].sensor);
  EXPECT_TRUE(s.bodies[1].sensor);
  const std::string text = scene_to_json(s);
  EXPECT_EQ(text.find("sensor"), text.rfind("sensor")) << "written once, for body 7 only";
  EXPECT_TRUE(parse_scene_json(text, "roundtrip").bodies[1].sensor);
  const std::string e = scene_error_of(scene_text(R"({"id": 7, "type": "dynamic", "mass": 1,
      "shape": {"type": "sphere", "radius": 0.5}, "position": [0, 2, 0], "sensor": 1})"));
  EXPECT_NE(e.find("(id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("'sensor': must be true or false"), std::string::npos) << e;
}

// Compound shapes (docs/scene-format.md, "Compound shapes"): children with
// poses round trip bit for bit; an empty compound, a nested one and bad
// child poses are errors naming the body and the field.
TEST(SceneJson, CompoundRoundTrips) {
  Scene s;
  s.name = "compound";
  Body b;
  b.id = 3;
  b.shape = Shape::compound({CompoundChild{Shape::box(Vec3(0.5, 0.1, 0.5)), Vec3(0, 0.4, 0), Quat::Identity()},
                             CompoundChild{Shape::capsule(0.1, 0.6), Vec3(0.3, -0.2, 0.1),
                                           Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()))}});
  b.position = Vec3(0, 2, 0);
  s.bodies.push_back(b);
  validate_scene(s, "compound");
  const Scene r = parse_scene_json(scene_to_json(s), "compound");
  const Shape& c = r.bodies[0].shape;
  ASSERT_EQ(c.kind, ShapeKind::Compound);
  ASSERT_EQ(c.children.size(), 2u);
  EXPECT_EQ(c.children[0].shape.kind, ShapeKind::Box);
  EXPECT_EQ(c.children[1].shape.height, 0.6);
  EXPECT_EQ(c.children[1].position, Vec3(0.3, -0.2, 0.1));
  EXPECT_EQ(c.children[1].orientation.coeffs(), b.shape.children[1].orientation.coeffs());
  // Half extents about the origin hold every child: in y the capsule's
  // (0.2 below the origin, 0.1 x 0.4 turned 0.3 rad), not the box's 0.5.
  EXPECT_NEAR(c.local_half_extents().y(), 0.2 + 0.1 * std::sin(0.3) + 0.4 * std::cos(0.3), 1e-12);
  EXPECT_GE(c.bounding_radius(), 0.5);
}

TEST(SceneErrors, BadCompoundsAreRejected) {
  auto body = [](const std::string& shape) {
    return R"({"id": 7, "type": "dynamic", "mass": 1, "position": [0, 2, 0], "shape": )" + shape + "}";
  };
  std::string e = scene_error_of(scene_text(body(R"({"type": "compound", "children": []})")));
  EXPECT_NE(e.find("(id 7): field 'shape.children': a compound needs at least one child shape"), std::string::npos) << e;
  e = scene_error_of(scene_text(body(
      R"({"type": "compound", "children": [{"shape": {"type": "compound", "children": [{"shape": {"type": "sphere", "radius": 1}}]}}]})")));
  EXPECT_NE(e.find("(id 7): field 'shape.children[0].shape.type': nested compounds are not supported"),
            std::string::npos) << e;
  e = scene_error_of(scene_text(body(
      R"({"type": "compound", "children": [{"shape": {"type": "sphere", "radius": 1}}, {"shape": {"type": "box", "half_extents": [1, -1, 1]}}]})")));
  EXPECT_NE(e.find("(id 7): field 'shape.children[1].shape.half_extents': must be > 0"), std::string::npos) << e;
  e = scene_error_of(scene_text(body(
      R"({"type": "compound", "children": [{"shape": {"type": "sphere", "radius": 1}, "pose": [0, 0, 0]}]})")));
  EXPECT_NE(e.find("'shape.children[0].pose': unknown field"), std::string::npos) << e;
  // NaN poses cannot be written in JSON; through the API they are refused.
  Scene s;
  Body b;
  b.id = 4;
  b.shape = Shape::compound({CompoundChild{Shape::sphere(0.5), Vec3(0, NAN, 0), Quat::Identity()}});
  s.bodies.push_back(b);
  try {
    validate_scene(s, "api");
    ADD_FAILURE() << "a NaN child position was accepted";
  } catch (const SceneError& err) {
    EXPECT_NE(std::string(err.what()).find("body #0 (id 4): field 'shape.children[0].position'"), std::string::npos)
        << err.what();
  }
  s.bodies[0].shape.children[0].position = Vec3::Zero();
  s.bodies[0].shape.children[0].orientation = Quat(0, 0, 0, 0);
  EXPECT_THROW(validate_scene(s, "api"), SceneError);
}

TEST(SceneErrors, MalformedJsonIsRejected) {
  const std::string e = scene_error_of(R"({"format": "soda-scene", "version": 1, "bodies": [)");
  EXPECT_NE(e.find("not valid JSON"), std::string::npos) << e;
}

TEST(SceneErrors, UnreadableFileIsRejected) {
  try {
    load_scene_file("/nonexistent/dir/scene.json");
    FAIL() << "no error";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/scene.json: cannot open"), std::string::npos)
        << e.what();
  }
}

TEST(SceneErrors, HugeBodyBulletWouldDisableIsRejected) {
  // 1e6 m box: AABB length^2 = 3e12 >= 1e12.
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [5e5, 5e5, 5e5]},
          "position": [0, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("1e12"), std::string::npos) << e;
}

TEST(SceneErrors, FarAwayCoordinatesBulletWouldDisableAreRejected) {
  // Beyond float range a float world's AABB is infinite: Bullet disables the
  // body. (Far below that, float merely loses precision; the far-origin
  // stress scenes measure it.)
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
          "position": [1e39, 2, 0]})"));
  EXPECT_NE(e.find("body #1 (id 7)"), std::string::npos) << e;
  EXPECT_NE(e.find("too far from the origin"), std::string::npos) << e;
}

TEST(SceneErrors, TooFastBodyBulletWouldDisableIsRejected) {
  const std::string e = scene_error_of(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "sphere", "radius": 0.5},
          "position": [0, 2, 0], "linear_velocity": [1e9, 0, 0]})"));
  EXPECT_NE(e.find("'position/shape/linear_velocity'"), std::string::npos) << e;
}

TEST(SceneErrors, FarButReasonableCoordinatesAreAccepted) {
  // The far-origin stress scenes live at 1e5 m: must load.
  EXPECT_NO_THROW(parse_scene_json(scene_text(
      R"({"id": 7, "type": "dynamic", "mass": 1, "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
          "position": [1e5, 2, 0]})"), "far.json"));
}

TEST(SceneErrors, BadSettingsAreRejected) {
  const std::string e = scene_error_of(R"({"format": "soda-scene", "version": 1, "settings": {"dt": -1},
      "bodies": []})");
  EXPECT_NE(e.find("settings: field 'dt'"), std::string::npos) << e;
}

}  // namespace
}  // namespace soda
