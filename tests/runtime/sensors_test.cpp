// Sensors (Body::sensor, sensor_reader.h, docs/contact-events.md "Sensors"):
// a sensor touches nothing — every other body moves bit for bit as in the
// scene without it — and a SensorReader reports the bodies it overlaps at
// each committed step, the same stream for any number of territories,
// partition, schedule and speculation with rollbacks. Label "concurrency"
// (ThreadSanitizer in CI): readers run while the worlds do.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"
#include "soda/runtime/world_metrics.h"

namespace soda {
namespace {

Body sensor_box(BodyId id, const Vec3& at, const Vec3& half_extents) {
  Body b;
  b.id = id;
  b.is_static = true;
  b.sensor = true;
  b.shape.kind = ShapeKind::Box;
  b.shape.half_extents = half_extents;
  b.position = at;
  return b;
}

// The scene's dynamic bodies' box: where sensors go.
void dynamic_bounds(const Scene& s, Vec3& lo, Vec3& hi) {
  lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
  for (const Body& b : s.bodies)
    if (!b.is_static) lo = lo.cwiseMin(b.position), hi = hi.cwiseMax(b.position);
}

// `s` with sensors added: a static slab across the middle of the falling
// bodies (they fall through it), a static box at the bottom around part of
// the pile that reports the ground too (it is static: it does not), and a
// dynamic sphere sensor thrown across the scene through everything,
// passing through the ground.
Scene with_sensors(Scene s) {
  Vec3 lo, hi;
  dynamic_bounds(s, lo, hi);
  const Vec3 mid = 0.5 * (lo + hi);
  const Vec3 half = 0.5 * (hi - lo) + Vec3(1, 0, 1);
  BodyId id = test::unused_id(s);
  s.bodies.push_back(sensor_box(id++, Vec3(mid.x(), mid.y(), mid.z()), Vec3(half.x(), 0.5, half.z())));
  s.bodies.push_back(sensor_box(id++, Vec3(lo.x() + 0.25 * (hi.x() - lo.x()), 1.0, mid.z()),
                                Vec3(0.25 * (hi.x() - lo.x()) + 0.5, 1.0, half.z())));
  Body ball;
  ball.id = id++;
  ball.sensor = true;
  ball.shape.kind = ShapeKind::Sphere;
  ball.shape.radius = 3.0;
  ball.position = Vec3(lo.x(), hi.y(), mid.z());
  ball.linear_velocity = Vec3(0.75 * (hi.x() - lo.x()), -4, 0);  // across territory borders: migrations, ghosts
  s.bodies.push_back(ball);
  return s;
}

// Steps from .. steps (a reader's thread: an error is a test failure, not a
// terminate).
std::vector<SensorStep> read_all(SensorReader& reader, int steps, int from = 0) {
  std::vector<SensorStep> out;
  try {
    for (int t = from; t <= steps; ++t) {
      std::optional<SensorStep> s = reader.read_step(t);
      if (!s) break;
      out.push_back(std::move(*s));
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << "SensorReader: " << e.what();
  }
  return out;
}

struct Tally {
  std::size_t begins = 0, ends = 0, inside = 0;
  std::vector<BodyId> sensors_seen;
};

Tally tally(const std::vector<SensorStep>& steps) {
  Tally t;
  for (const SensorStep& s : steps) {
    for (const SensorEvent& e : s.events) {
      (e.kind == SensorEventKind::Begin ? t.begins : t.ends) += 1;
      t.sensors_seen.push_back(e.sensor);
    }
    t.inside += s.inside.size();
  }
  std::sort(t.sensors_seen.begin(), t.sensors_seen.end());
  t.sensors_seen.erase(std::unique(t.sensors_seen.begin(), t.sensors_seen.end()), t.sensors_seen.end());
  return t;
}

// "" if equal; else the first difference.
std::string stream_difference(const std::vector<SensorStep>& got, const std::vector<SensorStep>& want) {
  if (got.size() != want.size()) return std::to_string(got.size()) + " steps, expected " + std::to_string(want.size());
  for (std::size_t t = 0; t < want.size(); ++t) {
    if (got[t].step != want[t].step || got[t].inside != want[t].inside) return "step " + std::to_string(t) + ": inside";
    if (got[t].events.size() != want[t].events.size()) return "step " + std::to_string(t) + ": event count";
    for (std::size_t i = 0; i < want[t].events.size(); ++i) {
      const SensorEvent& a = got[t].events[i];
      const SensorEvent& b = want[t].events[i];
      if (a.step != b.step || a.kind != b.kind || a.sensor != b.sensor || a.body != b.body)
        return "step " + std::to_string(t) + ": event " + std::to_string(i);
    }
  }
  return "";
}

// A sensor touches nothing: every other body's pose is the scene without
// sensors' bit for bit, step by step; the dynamic sensor falls through the
// ground.
TEST(Sensors, TouchNothing) {
  constexpr int kSteps = 90;
  const Scene plain = test::scene("cube-pile", 64);
  const Scene s = with_sensors(plain);
  const test::Reference want = test::reference_run(plain, kSteps);
  const test::Reference got = test::reference_run(s, kSteps);
  const BodyId ball = s.bodies.back().id;
  for (int t = 0; t <= kSteps; ++t) {
    std::vector<ScenePose> frame;
    for (const ScenePose& p : got.frames[t])
      if (p.id != ball) frame.push_back(p);
    ASSERT_EQ(test::frame_difference(frame, want.frames[t]), "") << "step " << t;
  }
  const ScenePose& end = got.frames[kSteps].back();
  ASSERT_EQ(end.id, ball);
  EXPECT_LT(end.position[1], -1.0) << "the sensor ball fell through the ground";
}

// The events at the steps the geometry says: a cube falls straight through
// a slab sensor; it is inside exactly while its box and the slab overlap
// (steps within 1 mm of touching are not judged). A cube outside the
// sensor's mask, and a second sensor inside the first, are never reported;
// queries skip sensors unless asked.
TEST(Sensors, ReportWhatOverlapsAtTheStepsTheGeometrySays) {
  Scene s = test::scene("falling-cubes", 1);
  s.bodies.erase(std::remove_if(s.bodies.begin(), s.bodies.end(), [](const Body& b) { return !b.is_static; }),
                 s.bodies.end());
  BodyId id = test::unused_id(s);
  const BodyId cube = id++, hidden = id++, slab = id++, inner = id++;
  Body c = test::new_cube(cube, Vec3(0, 12, 0));
  c.linear_velocity = Vec3(0, -6, 0);
  Body h = test::new_cube(hidden, Vec3(3, 12, 0));
  h.linear_velocity = Vec3(0, -6, 0);
  h.collision_group = 2;
  s.bodies.push_back(c);
  s.bodies.push_back(h);
  Body sb = sensor_box(slab, Vec3(0, 6, 0), Vec3(5, 0.5, 5));
  sb.collision_mask = 1;  // cubes of group 1 only
  s.bodies.push_back(sb);
  s.bodies.push_back(sensor_box(inner, Vec3(0, 6, 0), Vec3(0.5, 0.25, 0.5)));
  const double half = c.shape.half_extents.y();
  constexpr int kSteps = 120;
  Simulation sim(s, SimulationConfig{.territories = 2});
  SceneReader frames = sim.add_reader();
  SensorReader sensors = sim.add_sensor_reader();
  sim.start(sim.time_of(kSteps));
  int inside_steps = 0, judged = 0;
  std::size_t begins = 0, ends = 0;
  for (int t = 0; t <= kSteps; ++t) {
    std::optional<SensorStep> got = sensors.read_step(t);
    std::optional<SceneFrame> f = frames.read_at(sim.time_of(t));
    ASSERT_TRUE(got && f);
    const double y = f->find(cube)->position[1];
    const double gap = std::max(y - half - 6.5, 5.5 - (y + half));  // > 0: apart
    const bool in = std::find(got->inside.begin(), got->inside.end(), SensorOverlap{slab, cube}) != got->inside.end();
    if (std::abs(gap) > 1e-3) {
      ++judged;
      EXPECT_EQ(in, gap < 0) << "step " << t << " y " << y;
    }
    inside_steps += in;
    for (const SensorOverlap& o : got->inside) {
      EXPECT_NE(o.body, hidden) << "outside the sensor's mask";
      EXPECT_NE(o.body, inner) << "a sensor is never reported";
      EXPECT_NE(o.body, slab);
    }
    for (const SensorEvent& e : got->events) (e.kind == SensorEventKind::Begin ? begins : ends) += 1;
    if (t == 30) {  // a query made here, read at once and dropped: a reader that stops reading holds the run
      SceneQuery query = sim.add_query();
      auto ray = query.ray_cast_all(sim.time_of(t), Vec3(0, 20, 0), Vec3(0, 5.9, 0));
      ASSERT_TRUE(ray);
      for (const QueryHit& hit : ray->items) EXPECT_NE(hit.id, slab) << "queries skip sensors by default";
      auto with = query.ray_cast_all(sim.time_of(t), Vec3(0, 20, 0), Vec3(0, 5.9, 0), QueryFilter{.sensors = true});
      ASSERT_TRUE(with);
      EXPECT_TRUE(std::any_of(with->items.begin(), with->items.end(), [&](const QueryHit& h) { return h.id == slab; }));
    }
  }
  sim.stop();
  EXPECT_GT(inside_steps, 2);
  EXPECT_GT(judged, kSteps - 4);
  EXPECT_EQ(begins, 2u);  // the cube, and the inner sensor's view of it
  EXPECT_EQ(ends, 2u);
}

// The stream of sensors over a scene, and its state hash, for K worlds with
// speculation and rollbacks: the one-territory lockstep run's.
using Case = test::SpeculationCase;

class SensorsAnyK : public ::testing::TestWithParam<Case> {};

TEST_P(SensorsAnyK, StreamEqualsOneTerritory) {
  const Case c = GetParam();
  constexpr int kSteps = 80;
  const Scene s = with_sensors(test::scene(c.scene, c.bodies));
  std::vector<SensorStep> want;
  {
    Simulation one(s, SimulationConfig{.territories = 1, .threads = 1});
    std::jthread reader([&, r = one.add_sensor_reader()]() mutable { want = read_all(r, kSteps); });
    EXPECT_TRUE(one.advance_to(one.time_of(kSteps)));
    reader.join();
  }
  const Tally w = tally(want);
  ASSERT_EQ(want.size(), kSteps + 1u);
  EXPECT_GT(w.begins, 10u);
  EXPECT_GT(w.ends, 3u);
  EXPECT_GE(w.sensors_seen.size(), 2u);
  EXPECT_TRUE(std::binary_search(w.sensors_seen.begin(), w.sensors_seen.end(), s.bodies.back().id))
      << "the dynamic sensor saw something";
  // On terrain the dynamic sensor passes through the heightfield: a sensor
  // reports a static mesh or heightfield as it reports a box.
  for (const Body& b : s.bodies) {
    if (!b.is_static || (b.shape.kind != ShapeKind::Heightfield && b.shape.kind != ShapeKind::TriangleMesh)) continue;
    bool seen = false;
    for (const SensorStep& st : want)
      for (const SensorOverlap& o : st.inside) seen = seen || (o.sensor == s.bodies.back().id && o.body == b.id);
    EXPECT_TRUE(seen) << "the dynamic sensor never reported body " << b.id;
  }
  const TerritoryMap map = make_partition(c.partition, s, c.territories, GridOptions{});
  Simulation sim(s, map, test::speculation_config(c));
  std::vector<SensorStep> got;
  std::jthread reader([&, r = sim.add_sensor_reader()]() mutable { got = read_all(r, kSteps); });
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  reader.join();
  EXPECT_EQ(stream_difference(got, want), "");
  EXPECT_EQ(hash_hex(sensor_stream_hash(got)), hash_hex(sensor_stream_hash(want)));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(test::reference_hash(s, kSteps)));
  const WorldMetrics t = test::total(sim.metrics());
  std::printf("[ %s %d %s K=%d threads %d anticipation %d ] %zu begins, %zu ends; %llu rollbacks\n", c.scene,
              c.bodies, c.partition, c.territories, c.threads, c.anticipation, w.begins, w.ends,
              (unsigned long long)t.rollbacks);
  if (c.anticipation > 0 && c.threads == 1) EXPECT_GT(t.rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Sensors, SensorsAnyK,
    ::testing::Values(Case{"falling-cubes", 100, 8, "grid:8x1x1", 1, 8},  // rolls back in every run
                      Case{"cube-pile", 64, 4, "grid:4x1x1", 1, 8},
                      Case{"cube-pile", 64, 4, "kmeans", 0, 8},           // a thread per world
                      Case{"cube-pile", 64, 2, "rcb", 2, 0},              // a pool of 2, lockstep
                      Case{"terrain", 40, 4, "grid:4x1x1", 1, 8}),        // over a heightfield
    test::speculation_case_name);

// A body removed while inside ends at the step it is gone; reads go
// forward, and the last step read again is the same.
TEST(Sensors, RemovedBodyEndsAndReadsGoForward) {
  Scene s = test::scene("falling-cubes", 1);
  s.bodies.erase(std::remove_if(s.bodies.begin(), s.bodies.end(), [](const Body& b) { return !b.is_static; }),
                 s.bodies.end());
  BodyId id = test::unused_id(s);
  const BodyId cube = id++, zone = id++;
  s.bodies.push_back(test::new_cube(cube, Vec3(0, 3, 0)));
  s.bodies.push_back(sensor_box(zone, Vec3(0, 3, 0), Vec3(2, 2, 2)));
  Simulation sim(s, SimulationConfig{.territories = 1});
  SensorReader sensors = sim.add_sensor_reader();
  sim.remove_body(sim.time_of(10), cube);
  sim.start(sim.time_of(20));
  std::optional<SensorStep> first = sensors.read_step(0);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->events.size(), 1u);
  EXPECT_EQ(first->events[0].kind, SensorEventKind::Begin);
  std::optional<SensorStep> skip = sensors.read_step(10);  // diffed against step 9
  ASSERT_TRUE(skip);
  EXPECT_TRUE(skip->events.empty());
  EXPECT_EQ(skip->inside.size(), 1u);
  std::optional<SensorStep> gone = sensors.read_step(11);  // removed after step 10: gone from frame 11
  ASSERT_TRUE(gone);
  ASSERT_EQ(gone->events.size(), 1u);
  EXPECT_EQ(gone->events[0].kind, SensorEventKind::End);
  EXPECT_EQ(gone->events[0].body, cube);
  EXPECT_TRUE(gone->inside.empty());
  std::optional<SensorStep> again = sensors.read_step(11);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->events.size(), 1u);
  EXPECT_FALSE(sensors.read_step(5)) << "reads go forward";
  EXPECT_THROW(sensors.read_step(-1), std::invalid_argument);
  sim.stop();
}

// A checkpoint carries the sensor flag (version 6): saved with sensors on 2
// territories, resumed on 4, the sensor stream and the hash go on as the
// uninterrupted run's; version 5 cannot say "sensor" and refuses by name.
TEST(Sensors, CheckpointCarriesThem) {
  constexpr int kSave = 30, kSteps = 70;
  const Scene s = with_sensors(test::scene("cube-pile", 64));
  std::vector<SensorStep> want;
  {
    Simulation one(s, SimulationConfig{.territories = 1});
    std::jthread reader([&, r = one.add_sensor_reader()]() mutable { want = read_all(r, kSteps); });
    EXPECT_TRUE(one.advance_to(one.time_of(kSteps)));
    reader.join();
  }
  Simulation sim(s, SimulationConfig{.territories = 2});
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSave)));
  const std::vector<std::uint8_t> bytes = encode_checkpoint(sim.snapshot());
  sim.stop();
  EXPECT_EQ(checkpoint_header(bytes).version, kCheckpointVersion);
  try {
    encode_checkpoint(decode_checkpoint(bytes, "v6"), 5);
    ADD_FAILURE() << "version 5 took a sensor";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("version 5 cannot hold body"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sensor"), std::string::npos) << e.what();
  }
  Simulation resumed(decode_checkpoint(bytes, "v6"), SimulationConfig{.territories = 4});
  std::vector<SensorStep> got;
  std::jthread reader([&, r = resumed.add_sensor_reader()]() mutable {
    got = read_all(r, kSteps, kSave);
  });
  EXPECT_TRUE(resumed.advance_to(resumed.time_of(kSteps)));
  reader.join();
  EXPECT_EQ(hash_hex(resumed.state_hash()), hash_hex(test::reference_hash(s, kSteps)));
  ASSERT_EQ(got.size(), std::size_t(kSteps - kSave + 1));
  ASSERT_EQ(got.front().step, kSave);
  EXPECT_EQ(got.front().inside, want[kSave].inside);  // the first step begins what is inside
  got.erase(got.begin());
  EXPECT_EQ(stream_difference(got, std::vector<SensorStep>(want.begin() + kSave + 1, want.end())), "");
}

}  // namespace
}  // namespace soda
