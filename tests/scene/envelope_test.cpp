// The precision envelope (envelope.h, docs/scene-format.md): what lies
// outside it for a precision is refused with a message naming the body and
// the field; every registered scene and every stress-suite scene lies
// inside it in both precisions.
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr Precision kBoth[] = {Precision::Float, Precision::Double};

Scene one_body(const Body& b) {
  Scene s;
  s.name = "t";
  s.bodies.push_back(b);
  return s;
}

Body cube(BodyId id = 7) {
  Body b;
  b.id = id;
  b.shape = Shape::box(Vec3::Constant(0.5));
  b.mass = 1.0;
  b.position = Vec3(0, 2, 0);
  return b;
}

// The error for `s` in `precision`, or "" if it is accepted.
std::string error_of(const Scene& s, Precision precision) {
  try {
    validate_scene(s, "t.json", precision);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

void expect_refused(const Scene& s, Precision precision, const std::string& needle) {
  const std::string e = error_of(s, precision);
  std::printf("[ %s ] %s\n", precision_name(precision), e.c_str());
  EXPECT_NE(e.find(needle), std::string::npos) << precision_name(precision) << ": " << e;
}

TEST(Envelope, EveryRegisteredAndStressSceneLiesInsideInBothPrecisions) {
  // Defaults, and the stress suite's parameters (bench/stress.cpp).
  std::vector<std::pair<std::string, SceneParams>> scenes;
  for (const SceneGenerator& g : scene_registry()) scenes.push_back({g.name, SceneParams{}});
  for (int k : {10, 20, 30}) scenes.push_back({"tower", {k, 1, false}});
  for (int k : {20, 30}) scenes.push_back({"pyramid", {k, 1, false}});
  for (int k : {10, 100, 1000, 100000}) scenes.push_back({"mass-ratio", {k, 1, false}});
  for (int v : {50, 200, 500}) scenes.push_back({"bullet-vs-wall", {v, 1, false}});
  for (int d : {1000, 10000, 100000}) scenes.push_back({"far-origin", {d, 1, false}});
  for (int n : {200, 1000}) scenes.push_back({"dense-pile", {n, 1, false}});
  scenes.push_back({"cube-pile", {100, 1, false}});
  scenes.push_back({"falling-cubes", {2000, 3, true}});
  for (const auto& [name, params] : scenes) {
    const Scene s = make_scene(name, params);
    for (Precision p : kBoth) EXPECT_EQ(error_of(s, p), "") << name << " n=" << params.n;
  }
}

TEST(Envelope, FarBodyWhosePositionNeverChangesIsRefused) {
  Body b = cube();
  b.position = Vec3(1e30, 2, 0);  // x + 100 m/s * dt == x in either precision
  b.linear_velocity = Vec3(100, 0, 0);
  for (Precision p : kBoth) expect_refused(one_body(b), p, "body #0 (id 7): field 'position': coordinate 1e+30 m");
  // 2e5 m: a float world moves a body at 0.8 m/s by less than an ulp per
  // step there; a double world is fine.
  b.position = Vec3(2e5, 2, 0);
  expect_refused(one_body(b), Precision::Float, "field 'position'");
  EXPECT_EQ(error_of(one_body(b), Precision::Double), "");
}

TEST(Envelope, MassesThatRoundToZeroOrInfinityAreRefused) {
  for (double mass : {1e-300, 1e300}) {
    Body b = cube();
    b.mass = mass;
    for (Precision p : kBoth) expect_refused(one_body(b), p, "body #0 (id 7): field 'mass'");
  }
  Body light = cube();
  light.mass = 1e-40;  // subnormal in float (its inverse overflows); fine in double
  expect_refused(one_body(light), Precision::Float, "field 'mass'");
  EXPECT_EQ(error_of(one_body(light), Precision::Double), "");
}

TEST(Envelope, StepThatRoundsAwayIsRefused) {
  Scene s = one_body(cube());
  s.settings.dt = 1e-300;
  for (Precision p : kBoth) expect_refused(s, p, "settings: field 'dt'");
  s.settings.dt = 1e-10;  // below float's resolution, above double's
  expect_refused(s, Precision::Float, "settings: field 'dt'");
  EXPECT_EQ(error_of(s, Precision::Double), "");
  s.settings.dt = 1e3;  // gravity alone moves a body 1e7 m in one step
  for (Precision p : kBoth) expect_refused(s, p, "field 'gravity'");
}

TEST(Envelope, SpinBulletWouldClampIsRefused) {
  Body b = cube();
  b.angular_velocity = Vec3(0, 100, 0);  // > pi/4 per 1/60 s step
  for (Precision p : kBoth) expect_refused(one_body(b), p, "field 'angular_velocity'");
  b.angular_velocity = Vec3(0, 40, 0);
  for (Precision p : kBoth) EXPECT_EQ(error_of(one_body(b), p), "");
}

TEST(Envelope, BodyTooSmallForItsPositionIsRefused) {
  Body b = cube();
  b.position = Vec3(5e4, 2, 0);
  b.shape = Shape::sphere(0.01);  // a float ulp at 5e4 m is 4 mm
  b.mass = 1e-3;
  expect_refused(one_body(b), Precision::Float, "field 'shape'");
  EXPECT_EQ(error_of(one_body(b), Precision::Double), "");
}

}  // namespace
}  // namespace soda
