// Border, stress and analytic scenes: valid, deterministic, the documented
// counts (docs/scenes.md), and the geometry each scene exists for.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "soda/scene/registry.h"
#include "soda/scene/scene_json.h"
#include "soda/scene/validate.h"

namespace soda {
namespace {

constexpr double kG = 9.81;
constexpr double kDt = 1.0 / 60.0;

const std::vector<std::string> kBorderScenes = {"seam-stack", "cross-traffic", "projectile", "chain"};
const std::vector<std::string> kStressScenes = {"tower",          "pyramid",    "mass-ratio",
                                                "bullet-vs-wall", "far-origin", "dense-pile"};
const std::vector<std::string> kAnalyticScenes = {"free-fall", "incline", "resting-stack",
                                                  "rolling-sphere"};

std::vector<std::string> all_new_scenes() {
  std::vector<std::string> all = kBorderScenes;
  all.insert(all.end(), kStressScenes.begin(), kStressScenes.end());
  all.insert(all.end(), kAnalyticScenes.begin(), kAnalyticScenes.end());
  return all;
}

std::vector<Body> dynamics(const Scene& s) {
  std::vector<Body> d;
  for (const Body& b : s.bodies)
    if (!b.is_static) d.push_back(b);
  return d;
}

const Body& by_id(const Scene& s, BodyId id) {
  for (const Body& b : s.bodies)
    if (b.id == id) return b;
  throw std::out_of_range("no body " + std::to_string(id));
}

// Union of the dynamic bodies' initial AABBs.
Eigen::AlignedBox3d dynamic_bounds(const Scene& s) {
  Eigen::AlignedBox3d box;
  for (const Body& b : dynamics(s)) {
    box.extend(b.position - b.aabb_half_extents());
    box.extend(b.position + b.aabb_half_extents());
  }
  return box;
}

TEST(BorderScenes, EveryNewSceneIsRegisteredValidAndDeterministic) {
  for (const std::string& name : all_new_scenes()) {
    SCOPED_TRACE(name);
    ASSERT_NE(find_scene_generator(name), nullptr);
    for (const int n : {0, 3}) {
      const Scene s = make_scene(name, {n, 7, false});  // validates
      EXPECT_EQ(s.name, name);
      EXPECT_EQ(s.seed, 7u);
      EXPECT_EQ(scene_to_json(s), scene_to_json(make_scene(name, {n, 7, false})));
      EXPECT_DOUBLE_EQ(s.settings.dt, kDt);
      EXPECT_EQ(s.settings.iterations, 10);
      // Statics first from id 0, then dynamics, ids contiguous in body order.
      for (std::size_t i = 0; i < s.bodies.size(); ++i) {
        EXPECT_EQ(s.bodies[i].id, i);
        EXPECT_EQ(s.bodies[i].is_static, i < s.static_count());
      }
      // The ground: id 0, a box with its top face at y = 0.
      const Body& ground = s.bodies.at(0);
      EXPECT_EQ(ground.shape.kind, ShapeKind::Box);
      EXPECT_DOUBLE_EQ(ground.position.y() + ground.shape.half_extents.y(), 0.0);
    }
  }
}

TEST(BorderScenes, SeedMattersOnlyForRandomScenes) {
  for (const std::string& name : all_new_scenes()) {
    SCOPED_TRACE(name);
    Scene a = make_scene(name, {0, 1, false}), b = make_scene(name, {0, 2, false});
    a.seed = b.seed = 0;
    const bool random = name == "far-origin" || name == "dense-pile";
    EXPECT_EQ(scene_to_json(a) != scene_to_json(b), random);
  }
}

TEST(BorderScenes, DocumentedBodyCounts) {
  struct Count {
    std::string name;
    int n;
    std::size_t statics, dynamics;
  };
  const std::vector<Count> counts = {
      {"seam-stack", 0, 1, 16},     {"seam-stack", 5, 1, 10},
      {"seam-stack", 50, 1, 100},   {"cross-traffic", 0, 1, 12},
      {"cross-traffic", 99, 1, 12}, {"projectile", 0, 5, 5},       {"chain", 0, 1, 16},
      {"chain", 8, 1, 8},            {"tower", 0, 1, 10},
      {"tower", 25, 1, 25},          {"pyramid", 0, 1, 55},
      {"pyramid", 4, 1, 10},        {"mass-ratio", 0, 1, 2},       {"bullet-vs-wall", 0, 2, 1},
      {"far-origin", 0, 1, 50},     {"dense-pile", 0, 5, 1000},    {"dense-pile", 37, 5, 37},
      {"free-fall", 0, 1, 1},       {"incline", 0, 2, 1},          {"resting-stack", 0, 1, 3},
      {"rolling-sphere", 0, 1, 1}};
  for (const Count& c : counts) {
    SCOPED_TRACE(c.name + " n=" + std::to_string(c.n));
    const Scene s = make_scene(c.name, {c.n, 1, false});
    EXPECT_EQ(s.static_count(), c.statics);
    EXPECT_EQ(s.dynamic_count(), c.dynamics);
  }
}

TEST(BorderScenes, BodiesFitOneTwoMetreCellAndHaloRuleHolds) {
  for (const std::string& name : all_new_scenes()) {
    SCOPED_TRACE(name);
    const Scene s = make_scene(name, {0, 3, false});
    EXPECT_LE(s.largest_dynamic_extent(), 2.0);
    // < 30 m/s: under half a metre per step. bullet-vs-wall breaks it on purpose.
    if (name == "bullet-vs-wall") continue;
    for (const Body& b : dynamics(s)) EXPECT_LT(b.linear_velocity.norm(), 30.0) << b.id;
  }
}

TEST(BorderScenes, BorderScenesAreSymmetricAboutXZero) {
  for (const std::string& name : kBorderScenes) {
    SCOPED_TRACE(name);
    const Eigen::AlignedBox3d box = dynamic_bounds(make_scene(name, {0, 1, false}));
    EXPECT_DOUBLE_EQ(box.min().x(), -box.max().x());
    if (name == "cross-traffic" || name == "projectile") {
      EXPECT_DOUBLE_EQ(box.min().z(), -box.max().z());
    }
  }
}

TEST(BorderScenes, SeamStackTowersStandOnTheSeamAndTheCorner) {
  const int n = 8;
  const Scene s = make_scene("seam-stack", {0, 1, false});
  const std::vector<Body> d = dynamics(s);
  ASSERT_EQ(d.size(), 2u * n);
  for (int t = 0; t < 2; ++t)
    for (int i = 0; i < n; ++i) {
      const Body& b = d[static_cast<std::size_t>(t * n + i)];
      EXPECT_EQ(b.id, static_cast<BodyId>(t * n + i + 1));
      EXPECT_EQ(b.position.x(), 0.0);                 // on the plane x = 0
      EXPECT_EQ(b.position.z(), t == 0 ? 3.0 : 0.0);  // then on the corner
      EXPECT_EQ(b.shape.half_extents, Vec3::Constant(0.5));
      EXPECT_TRUE(b.orientation.coeffs().isApprox(Quat::Identity().coeffs()));
      const double below = i == 0 ? 0.0 : d[static_cast<std::size_t>(t * n + i - 1)].position.y() + 0.5;
      EXPECT_NEAR(b.position.y() - 0.5 - below, i == 0 ? 0.0 : 0.001, 1e-12);  // ground, then 1 mm gaps
    }
}

TEST(BorderScenes, ChainBoxesTouchAndTheFirstIsPushed) {
  for (const int n : {16, 8, 9}) {
    SCOPED_TRACE(n);
    const std::vector<Body> d = dynamics(make_scene("chain", {n == 16 ? 0 : n, 1, false}));
    ASSERT_EQ(d.size(), static_cast<std::size_t>(n));
    EXPECT_EQ(d.front().position.x() - 0.5, -0.5 * n);  // spans [-L/2, L/2]
    EXPECT_EQ(d.back().position.x() + 0.5, 0.5 * n);
    for (std::size_t i = 0; i < d.size(); ++i) {
      EXPECT_EQ(d[i].position.y(), 0.5);
      EXPECT_EQ(d[i].friction, 0.5);
      if (i > 0) {
        EXPECT_EQ(d[i].position.x() - d[i - 1].position.x(), 1.0);  // touching
      }
      EXPECT_EQ(d[i].linear_velocity, i == 0 ? Vec3(3.0, 0.0, 0.0) : Vec3::Zero());
    }
  }
}

TEST(BorderScenes, CrossTrafficComesFromAllQuadrantsThroughTheBorders) {
  const Scene s = make_scene("cross-traffic", {0, 1, false});
  bool quadrant[2][2] = {};
  int on_border = 0, crossing = 0;
  for (const Body& b : dynamics(s)) {
    EXPECT_EQ(b.friction, 0.1);
    EXPECT_EQ(b.position.y(), 0.5);
    EXPECT_NEAR(b.linear_velocity.norm(), 5.0, 1e-12);
    EXPECT_LT(b.linear_velocity.dot(b.position), 0.0) << b.id;  // heading towards the origin
    const double x = b.position.x(), z = b.position.z();
    if (x != 0.0 && z != 0.0) quadrant[x > 0][z > 0] = true;
    if (x == 0.0 || z == 0.0) ++on_border;  // sliding along a border
    // Crosses x = 0 or z = 0 within 2 s on its initial line (no friction).
    const Vec3 later = b.position + 2.0 * b.linear_velocity;
    if (x * later.x() < 0.0 || z * later.z() < 0.0) ++crossing;
  }
  for (auto& row : quadrant)
    for (bool q : row) EXPECT_TRUE(q);
  EXPECT_EQ(on_border, 4);
  EXPECT_EQ(crossing, 12);  // every box passes through a border
  EXPECT_LE(s.bodies.size(), 40u);
}

TEST(BorderScenes, ProjectileBouncesInsideTheArena) {
  const Scene s = make_scene("projectile", {0, 1, false});
  for (BodyId id = 1; id <= 4; ++id) {
    const Body& w = by_id(s, id);
    EXPECT_TRUE(w.is_static);
    EXPECT_EQ(w.restitution, 0.8);
    // Inner face at 15 m from the centre.
    const double inner = std::max(std::abs(w.position.x()) - w.shape.half_extents.x(),
                                  std::abs(w.position.z()) - w.shape.half_extents.z());
    EXPECT_DOUBLE_EQ(inner, 15.0);
  }
  const Body& ball = by_id(s, 5);
  EXPECT_EQ(ball.shape.kind, ShapeKind::Sphere);
  EXPECT_EQ(ball.shape.radius, 0.25);
  EXPECT_EQ(ball.restitution, 0.8);
  EXPECT_DOUBLE_EQ(ball.linear_velocity.norm(), 20.0);
  EXPECT_EQ(ball.linear_velocity.y(), 0.0);
  EXPECT_EQ(ball.position.y(), 0.25);
}

TEST(BorderScenes, StressScenesMatchTheirParameters) {
  const std::vector<Body> tower = dynamics(make_scene("tower", {12, 1, false}));
  for (std::size_t i = 0; i < tower.size(); ++i) EXPECT_EQ(tower[i].position, Vec3(0.0, 0.5 + i, 0.0));

  const std::vector<Body> pyramid = dynamics(make_scene("pyramid", {0, 1, false}));
  EXPECT_EQ(pyramid.front().position.x(), -4.5);  // base of 10, centred
  EXPECT_EQ(pyramid.back().position, Vec3(0.0, 9.5, 0.0));  // apex

  for (const int ratio : {0, 10, 1000}) {
    const Scene s = make_scene("mass-ratio", {ratio, 1, false});
    EXPECT_EQ(by_id(s, 1).mass, 1.0);
    EXPECT_EQ(by_id(s, 2).mass, ratio == 0 ? 100.0 : ratio);
    EXPECT_GT(by_id(s, 2).position.y(), by_id(s, 1).position.y());  // heavy on light
  }

  for (const int speed : {0, 50}) {
    const Scene s = make_scene("bullet-vs-wall", {speed, 1, false});
    EXPECT_EQ(2 * by_id(s, 1).shape.half_extents.x(), 0.1);
    EXPECT_EQ(by_id(s, 2).shape.radius, 0.05);
    EXPECT_EQ(by_id(s, 2).linear_velocity.x(), speed == 0 ? 200.0 : speed);
  }

  // far-origin is cube-pile(50) moved n metres along x: same seed, same pile.
  const Scene pile = make_scene("cube-pile", {50, 4, false});
  for (const int n : {0, 1000, 100000}) {
    const Scene far = make_scene("far-origin", {n, 4, false});
    ASSERT_EQ(far.bodies.size(), pile.bodies.size());
    const double offset = n == 0 ? 1e4 : n;
    for (std::size_t i = 0; i < far.bodies.size(); ++i) {
      EXPECT_EQ(far.bodies[i].position, pile.bodies[i].position + Vec3(offset, 0.0, 0.0));
      EXPECT_EQ(far.bodies[i].orientation.coeffs(), pile.bodies[i].orientation.coeffs());
    }
  }
}

TEST(BorderScenes, DensePileStartsApartInsideTheBin) {
  const std::vector<Body> d = dynamics(make_scene("dense-pile", {300, 5, false}));
  for (std::size_t i = 0; i < d.size(); ++i) {
    const Vec3 h = d[i].aabb_half_extents();
    EXPECT_LT(h.maxCoeff(), 0.29);
    EXPECT_LE(std::abs(d[i].position.x()) + h.x(), 2.0);
    EXPECT_LE(std::abs(d[i].position.z()) + h.z(), 2.0);
    EXPECT_GT(d[i].position.y() - h.y(), 0.0);
    for (std::size_t j = 0; j < i; ++j) {
      const Vec3 gap = (d[i].position - d[j].position).cwiseAbs() - h - d[j].aabb_half_extents();
      EXPECT_GT(gap.maxCoeff(), 0.0) << i << " " << j;  // AABBs disjoint
    }
  }
}

TEST(BorderScenes, AnalyticScenesHaveTheirClosedForms) {
  // free-fall: no contact in the first 60 steps, nor in the scene's 180.
  const Scene fall = make_scene("free-fall", {0, 1, false});
  const Body& ball = by_id(fall, 1);
  EXPECT_EQ(ball.position.y(), 100.0);
  EXPECT_EQ(ball.linear_velocity, Vec3::Zero());
  const int steps = fall.settings.steps;
  EXPECT_GE(steps, 60);
  // Semi-implicit Euler: y_n = y_0 - g dt^2 n (n + 1) / 2.
  EXPECT_GT(ball.position.y() - kG * kDt * kDt * steps * (steps + 1) / 2 - ball.shape.radius, 0.0);
  EXPECT_LT(kG * kDt * steps, 30.0);

  // incline: 30 degrees, mu = 0.3 (the product of the two frictions), slides.
  const Scene incline = make_scene("incline", {0, 1, false});
  const Body& slope = by_id(incline, 1);
  const Body& box = by_id(incline, 2);
  const Vec3 normal = slope.orientation * Vec3::UnitY();
  EXPECT_NEAR(std::acos(normal.y()), std::numbers::pi / 6, 1e-12);
  const Vec3 top = slope.position + normal * slope.shape.half_extents.y();
  EXPECT_NEAR((box.position - top).dot(normal), 0.5, 1e-12);  // resting, zero gap
  const double mu = slope.friction * box.friction;
  EXPECT_DOUBLE_EQ(mu, 0.3);
  EXPECT_GT(std::tan(std::numbers::pi / 6), mu);
  EXPECT_TRUE(box.orientation.coeffs().isApprox(slope.orientation.coeffs()));

  // resting-stack: zero gaps.
  const std::vector<Body> stack = dynamics(make_scene("resting-stack", {0, 1, false}));
  for (std::size_t i = 0; i < stack.size(); ++i) EXPECT_EQ(stack[i].position, Vec3(0.0, 0.5 + i, 0.0));

  // rolling-sphere: the contact point is at rest, v + w x (-r y) = 0.
  const Body& roll = by_id(make_scene("rolling-sphere", {0, 1, false}), 1);
  EXPECT_EQ(roll.position.y(), roll.shape.radius);
  EXPECT_EQ(roll.linear_velocity, Vec3(2.0, 0.0, 0.0));
  EXPECT_EQ(roll.linear_velocity + roll.angular_velocity.cross(-roll.shape.radius * Vec3::UnitY()),
            Vec3::Zero());
}

}  // namespace
}  // namespace soda

namespace soda {
namespace {

TEST(BorderScenes, TooLargeCountIsAnErrorNotASilentDefault) {
  for (const auto& [name, n] : std::vector<std::pair<std::string, int>>{
           {"seam-stack", 51}, {"chain", 201}, {"tower", 101}, {"pyramid", 51}}) {
    SCOPED_TRACE(name);
    try {
      make_scene(name, {n, 1, false});
      ADD_FAILURE() << "no error for n = " << n;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("too large"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace soda
