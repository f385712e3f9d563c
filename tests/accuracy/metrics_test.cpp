// Error metrics: penetration from manifolds, energy, trajectory error of
// identical runs, trace files.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>

#include <unistd.h>

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include "soda/bench/accuracy.h"
#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

Body box(BodyId id, const Vec3& position, bool is_static = false) {
  Body b;
  b.id = id;
  b.is_static = is_static;
  b.shape = Shape::box(Vec3::Constant(0.5));
  b.mass = 1.0;
  b.position = position;
  return b;
}

TEST(Metrics, PenetrationFromManifoldsOfOverlappingBoxes) {
  // Two unit boxes overlapping by 0.1 m along x, no gravity: after one step
  // the manifold holds the contact at distance -0.1 (read before the solver
  // pushes them apart).
  Scene scene;
  scene.settings.gravity = Vec3::Zero();
  scene.bodies = {box(0, Vec3(0, 0, 0), true), box(1, Vec3(0.9, 0, 0))};
  CanonicalWorld world(scene);
  world.step();
  const PenetrationStats s = manifold_penetration(*world.bullet().getDispatcher());
  ASSERT_GT(s.points, 0);
  EXPECT_NEAR(s.max, 0.1, 1e-4);
  EXPECT_GT(s.mean(), 0.0);
  EXPECT_LE(s.mean(), s.max);
}

TEST(Metrics, NoPenetrationWithoutContacts) {
  Scene scene;
  scene.settings.gravity = Vec3::Zero();
  scene.bodies = {box(0, Vec3(0, 0, 0), true), box(1, Vec3(3, 0, 0))};
  CanonicalWorld world(scene);
  world.step();
  const PenetrationStats s = manifold_penetration(*world.bullet().getDispatcher());
  EXPECT_EQ(s.max, 0.0);
  EXPECT_EQ(s.mean(), 0.0);
}

TEST(Metrics, EnergyOfAKnownState) {
  Scene scene;
  Body b = box(1, Vec3(0, 2, 0));
  b.mass = 2.0;
  scene.bodies = {box(0, Vec3(0, -0.5, 0), true), b};
  BodySample s;
  s.id = 1;
  s.position[1] = 2.0;
  s.linear_velocity[0] = 3.0;
  s.angular_velocity[1] = 4.0;
  // Rotated 90 degrees about x: the body's y axis maps to the world's z, so
  // world omega_y is body omega about an axis with the same inertia (a cube).
  const Quat q(Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitX()));
  s.orientation[0] = q.x();
  s.orientation[1] = q.y();
  s.orientation[2] = q.z();
  s.orientation[3] = q.w();
  const double inertia = 2.0 / 12.0 * (1.0 + 1.0);  // m (a^2 + b^2) / 12, unit cube
  const double expected = 0.5 * 2.0 * 9.0 + 0.5 * inertia * 16.0 + 2.0 * 9.81 * 2.0;
  EXPECT_NEAR(total_energy(scene, {s}), expected, 1e-5 * expected);
}

TEST(Metrics, EnergyOfFreeFallIsConservedToTheDiscretisation) {
  // Semi-implicit Euler in free fall loses E_n - E_0 = -m g^2 dt^2 n / 2:
  // v_n = g dt n exactly, y_n trails the parabola by g dt^2 n / 2.
  Scene scene = make_scene("free-fall", {});
  TraceConfig c;
  c.steps = 60;
  c.sample_period = 1.0 / 60;
  const Trace t = record_trace(scene, c);
  const double g = 9.81, dt = 1.0 / 60;
  const double expected = 1.0 * g * g * dt * dt * 60 / 2.0;
  EXPECT_NEAR(t.energy.back() - t.energy.front(), -expected, 1e-3);  // float: |y| ulp 8e-6 m, 8e-5 J
}

TEST(Metrics, IdenticalRunsHaveZeroError) {
  Scene scene = make_scene("cube-pile", {40, 3, false});
  TraceConfig c;
  c.steps = 60;
  const Trace a = record_trace(scene, c);
  const Trace b = record_trace(scene, c);
  const ErrorMetrics e = compare_traces(scene, a, b);
  EXPECT_EQ(a.state_hash, b.state_hash);
  EXPECT_EQ(e.traj_rms, 0.0);
  EXPECT_EQ(e.traj_max, 0.0);
  EXPECT_EQ(e.angle_rms, 0.0);
  EXPECT_EQ(e.energy_err, 0.0);
  EXPECT_EQ(e.com_err, 0.0);
  EXPECT_EQ(e.height_rms, 0.0);
  EXPECT_EQ(e.top_err, 0.0);
  EXPECT_EQ(e.final_rms, 0.0);
  EXPECT_GT(e.pen_max, 0.0);  // the pile starts interpenetrating: its own penetration is not zero
}

TEST(Metrics, ShiftedRunHasTheShiftAsError) {
  Scene scene = make_scene("cube-pile", {40, 3, false});
  TraceConfig c;
  c.steps = 30;
  const Trace ref = record_trace(scene, c);
  Trace run = ref;
  auto shift = [](std::vector<BodySample>& v) {
    for (BodySample& s : v) s.position[0] += 0.25;
  };
  for (auto& h : run.horizon_states) shift(h);
  shift(run.final_states);
  const ErrorMetrics e = compare_traces(scene, run, ref);
  EXPECT_NEAR(e.traj_rms, 0.25, 1e-12);
  EXPECT_NEAR(e.traj_max, 0.25, 1e-12);
  EXPECT_NEAR(e.com_err, 0.25, 1e-12);
  EXPECT_NEAR(e.final_rms, 0.25, 1e-12);
  EXPECT_EQ(e.angle_rms, 0.0);
}

TEST(Metrics, BodiesThatFellOffTheGroundAreCountedNotAveraged) {
  Scene scene = make_scene("cube-pile", {40, 3, false});
  TraceConfig c;
  c.steps = 30;
  const Trace ref = record_trace(scene, c);
  Trace run = ref;
  run.final_states[7].position[1] = -150.0;  // slid off the edge and fell
  const ErrorMetrics e = compare_traces(scene, run, ref);
  EXPECT_EQ(e.lost_bodies, 1);
  EXPECT_EQ(e.ref_lost_bodies, 0);
  EXPECT_EQ(e.final_rms, 0.0);      // over bodies on the ground in both
  EXPECT_LT(e.com_err, 0.2);        // 39 of 40 bodies: a small shift, not 150 m / 40
  EXPECT_LT(std::abs(e.top_err), 1e-12);
}

TEST(Metrics, TraceFileRoundTripIsExact) {
  Scene scene = make_scene("falling-cubes", {30, 2, false});
  TraceConfig c;
  c.steps = 45;
  c.horizon = 0.5;
  const Trace t = record_trace(scene, c);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("soda-trace-test-" + std::to_string(::getpid()) + ".trace")).string();
  write_trace(t, path);
  const Trace u = read_trace(path);
  std::filesystem::remove(path);
  EXPECT_EQ(u.precision, t.precision);
  EXPECT_EQ(u.steps, t.steps);
  EXPECT_EQ(u.state_hash, t.state_hash);
  EXPECT_EQ(u.times, t.times);
  EXPECT_EQ(u.energy, t.energy);
  ASSERT_EQ(u.horizon_states.size(), t.horizon_states.size());
  EXPECT_EQ(t.horizon_states.size(), 16u);  // t = 0, 1/30, ..., 0.5
  const ErrorMetrics e = compare_traces(scene, u, t);
  EXPECT_EQ(e.traj_max, 0.0);
  EXPECT_EQ(e.final_rms, 0.0);
  EXPECT_EQ(u.penetration.max, t.penetration.max);
}

TEST(Metrics, RejectsBadSamplePeriodsAndCcdOnTheCanonicalWorld) {
  Scene scene = make_scene("free-fall", {});
  TraceConfig c;
  c.steps = 2;
  c.sample_period = 0.025;  // 1.5 steps of 1/60
  EXPECT_THROW(record_trace(scene, c), std::invalid_argument);
  c.sample_period = 1.0 / 30;
  c.ccd = true;
  EXPECT_THROW(record_trace(scene, c), std::invalid_argument);
  c.world = WorldKind::Stock;
  EXPECT_NO_THROW(record_trace(scene, c));
}

TEST(Metrics, HeightProfileAndCentreOfMass) {
  Scene scene;
  scene.bodies = {box(0, Vec3(0, -0.5, 0), true), box(1, Vec3(0.5, 0.5, 0.5)), box(2, Vec3(0.5, 1.5, 0.5)),
                  box(3, Vec3(4.5, 0.5, 0.5))};
  std::vector<BodySample> s(3);
  for (int i = 0; i < 3; ++i) {
    s[static_cast<std::size_t>(i)].id = static_cast<BodyId>(i + 1);
    for (int k = 0; k < 3; ++k)
      s[static_cast<std::size_t>(i)].position[k] = scene.bodies[static_cast<std::size_t>(i + 1)].position[k];
  }
  const auto cells = height_profile(scene, s, 2.0);
  ASSERT_EQ(cells.size(), 2u);
  EXPECT_DOUBLE_EQ(cells[0].top, 2.0);  // the two-box stack
  EXPECT_DOUBLE_EQ(cells[1].top, 1.0);
  const Vec3 com = centre_of_mass(scene, s);
  EXPECT_NEAR(com.x(), (0.5 + 0.5 + 4.5) / 3, 1e-12);
  EXPECT_NEAR(com.y(), 2.5 / 3, 1e-12);
}

}  // namespace
}  // namespace soda
