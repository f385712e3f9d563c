// Queries at a time (docs/embedding.md, "Queries"): rays, sweeps and
// overlaps answered from the committed frame of a step give the same ids and
// bits for K = 1, 4 and 8, lockstep and speculating with lost bets, asked
// from a thread of their own while the worlds run; a query never answers
// from a step that is later rolled back (its answers would then differ from
// one world's). Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

constexpr int kSteps = 90;
constexpr int kEvery = 6;

// Every query of one step, written as text with every double's bits, so
// that two runs compare with one string comparison and a difference shows.
std::string bits(double v) {
  std::uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  std::ostringstream s;
  s << std::hex << u;
  return s.str();
}

std::string describe(const std::optional<QueryResult<QueryHit>>& r) {
  if (!r) return "none;";
  std::ostringstream s;
  s << "step " << r->step << ":";
  for (const QueryHit& h : r->items)
    s << " " << h.id << "@" << bits(h.fraction) << "," << bits(h.point.x()) << "," << bits(h.point.y()) << ","
      << bits(h.point.z()) << "," << bits(h.normal.x()) << "," << bits(h.normal.y()) << "," << bits(h.normal.z());
  return s.str() + ";";
}

std::string describe(const std::optional<QueryResult<BodyId>>& r) {
  if (!r) return "none;";
  std::ostringstream s;
  s << "step " << r->step << ":";
  for (BodyId id : r->items) s << " " << id;
  return s.str() + ";";
}

// Rays straight down on a 7 x 7 grid over the scene, a slanted ray through
// it, a sphere swept across it, a box and an AABB overlapping its middle.
std::string ask(SceneQuery& q, double time, std::size_t* hits) {
  std::string out;
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j) {
      auto r = q.ray_cast(time, Vec3(3.0 * i, 30, 3.0 * j), Vec3(3.0 * i, -5, 3.0 * j));
      if (r) *hits += r->items.size();
      out += describe(r);
    }
  auto all = q.ray_cast_all(time, Vec3(-20, 6, -20), Vec3(20, 0, 20));
  if (all) *hits += all->items.size();
  out += describe(all);
  out += describe(q.sweep(time, Shape::sphere(0.8), Vec3(-20, 2, 0), Vec3(20, 2, 0)));
  out += describe(q.overlap(time, Shape::box(Vec3(3, 2, 3)), Vec3(0, 1.5, 0)));
  out += describe(q.overlap_aabb(time, Vec3(-4, 0, -4), Vec3(4, 3, 4), QueryFilter{.statics = false}));
  return out;
}

struct QueryRun {
  std::vector<std::string> answers;  // per queried step
  std::size_t hits = 0;
  WorldMetrics totals;
};

// One territory, stepping by hand: the reference.
QueryRun reference(const Scene& s) {
  QueryRun r;
  Simulation one(s, SimulationConfig{.threads = 1});
  SceneQuery q = one.add_query();
  for (int k = 0; k <= kSteps; k += kEvery) {
    EXPECT_TRUE(one.advance_to(one.time_of(k)));
    r.answers.push_back(ask(q, one.time_of(k), &r.hits));
  }
  return r;
}

// K territories running freely; the queries on a thread of their own.
QueryRun running(const Scene& s, const TerritoryMap& map, int anticipation) {
  QueryRun r;
  SimulationConfig config{.buffer_capacity = 24};
  config.runtime.anticipation = anticipation;
  config.runtime.eager_bets = anticipation > 0;
  Simulation sim(s, map, config);
  SceneQuery q = sim.add_query();
  sim.start(sim.time_of(kSteps));
  std::thread asking([&] {
    for (int k = 0; k <= kSteps; k += kEvery) r.answers.push_back(ask(q, sim.time_of(k), &r.hits));
  });
  asking.join();
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  r.totals = test::total(sim.metrics());
  return r;
}

TEST(SceneQuery, AnswersAreTheSameForEveryTerritoryCount) {
  const Scene s = test::scene("falling-cubes", 150);
  const QueryRun ref = reference(s);
  ASSERT_EQ(ref.answers.size(), static_cast<std::size_t>(kSteps / kEvery + 1));
  EXPECT_GT(ref.hits, 200u);  // the rays and the sweep do hit bodies
  struct Case {
    const char* partition;
    int k;
    int anticipation;
  };
  for (const Case& c : {Case{"kmeans", 4, 0}, Case{"grid:8x1x1", 8, 0}, Case{"grid:8x1x1", 8, 8}}) {
    const TerritoryMap map = make_partition(c.partition, s, c.k, GridOptions{});
    const QueryRun run = running(s, map, c.anticipation);
    std::printf("[ falling-cubes 150, %s K %d anticipation %d ] %zu hits over %zu queried steps; %llu bets, %llu "
                "lost, %llu rollbacks\n",
                c.partition, c.k, c.anticipation, run.hits, run.answers.size(),
                static_cast<unsigned long long>(run.totals.bets), static_cast<unsigned long long>(run.totals.bets_lost),
                static_cast<unsigned long long>(run.totals.rollbacks));
    ASSERT_EQ(run.answers.size(), ref.answers.size());
    for (std::size_t i = 0; i < ref.answers.size(); ++i)
      EXPECT_EQ(run.answers[i], ref.answers[i]) << c.partition << " K " << c.k << ", step " << i * kEvery;
    if (c.anticipation > 0) EXPECT_GT(run.totals.rollbacks, 0u);  // speculative steps were taken back
  }
}

TEST(SceneQuery, FiltersAndCanonicalOrder) {
  const Scene s = test::scene("cube-pile", 60);
  Simulation sim(s, SimulationConfig{.territories = 2});
  SceneQuery q = sim.add_query();
  ASSERT_TRUE(sim.advance_to(sim.time_of(30)));
  auto all = q.ray_cast_all(sim.time_of(30), Vec3(0, 40, 0), Vec3(0, -2, 0));
  ASSERT_TRUE(all.has_value());
  EXPECT_EQ(all->step, 30);
  ASSERT_GE(all->items.size(), 2u);  // cubes of the pile and the ground
  for (std::size_t i = 1; i < all->items.size(); ++i) EXPECT_LE(all->items[i - 1].fraction, all->items[i].fraction);
  const BodyId first = all->items.front().id;
  auto closest = q.ray_cast(sim.time_of(30), Vec3(0, 40, 0), Vec3(0, -2, 0), QueryFilter{.ignore = {first}});
  ASSERT_TRUE(closest && closest->items.size() == 1);
  EXPECT_EQ(closest->items[0].id, all->items[1].id);
  auto statics = q.ray_cast_all(sim.time_of(30), Vec3(0, 40, 0), Vec3(0, -2, 0), QueryFilter{.dynamics = false});
  ASSERT_TRUE(statics && statics->items.size() == 1);
  EXPECT_EQ(statics->items[0].id, 0u);  // the ground
  EXPECT_NEAR(statics->items[0].normal.y(), 1.0, 1e-6);
  EXPECT_THROW(q.ray_cast(sim.time_of(30), Vec3(0, NAN, 0), Vec3(0, 0, 0)), std::invalid_argument);
}

// QueryFilter::mask sees the bodies whose collision group shares a bit
// with it: the pile's cubes in group 2 (they still land on the ground, whose
// group is the default 1), the ground in 1.
TEST(SceneQuery, MaskSelectsBodiesByCollisionGroup) {
  Scene s = test::scene("cube-pile", 60);
  for (Body& b : s.bodies)
    if (!b.is_static) b.collision_group = 2;
  Simulation sim(s, SimulationConfig{.territories = 2});
  SceneQuery q = sim.add_query();
  ASSERT_TRUE(sim.advance_to(sim.time_of(30)));
  const Vec3 from(0, 40, 0), to(0, -2, 0);
  auto all = q.ray_cast_all(sim.time_of(30), from, to);
  auto cubes = q.ray_cast_all(sim.time_of(30), from, to, QueryFilter{.mask = 2});
  auto ground = q.ray_cast_all(sim.time_of(30), from, to, QueryFilter{.mask = 1});
  auto none = q.ray_cast_all(sim.time_of(30), from, to, QueryFilter{.mask = 4});
  ASSERT_TRUE(all && cubes && ground && none);
  ASSERT_GE(all->items.size(), 2u);
  EXPECT_EQ(cubes->items.size() + 1, all->items.size());
  for (const QueryHit& h : cubes->items) EXPECT_NE(h.id, 0u);
  ASSERT_EQ(ground->items.size(), 1u);
  EXPECT_EQ(ground->items[0].id, 0u);
  EXPECT_TRUE(none->items.empty());
}

}  // namespace
}  // namespace soda

namespace soda {
namespace {

// Queries over level geometry: rays straight down on a grid over the
// bodies of terrain (a heightfield) and city (a triangle-mesh street grid)
// hit the ground and the bodies on it with the same ids and fraction bits
// for 4 speculating territories as for one; a dynamic sensor falling with
// the bodies reports what it overlaps, the same for both (and, on the
// heightfield, the ground).
TEST(SceneQuery, OverMeshesAndHeightfieldsTheSameForEveryTerritoryCount) {
  constexpr int kLast = 60, kEach = 10;
  for (const char* name : {"terrain", "city"}) {
    Scene s = test::scene(name, 40);
    Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
    std::vector<BodyId> statics;
    for (const Body& b : s.bodies) {
      if (b.is_static) statics.push_back(b.id);
      else lo = lo.cwiseMin(b.position), hi = hi.cwiseMax(b.position);
    }
    Body probe;
    probe.id = test::unused_id(s);
    probe.sensor = true;
    probe.shape = Shape::sphere(3.0);
    probe.position = Vec3(0.5 * (lo.x() + hi.x()), lo.y(), 0.5 * (lo.z() + hi.z()));  // falls onto the ground, and through
    s.bodies.push_back(probe);
    std::size_t ground_hits = 0;
    auto ask_down = [&](SceneQuery& q, double time) {
      std::string out;
      for (int i = 0; i <= 6; ++i)
        for (int j = 0; j <= 6; ++j) {
          const double x = lo.x() + (hi.x() - lo.x()) * i / 6.0, z = lo.z() + (hi.z() - lo.z()) * j / 6.0;
          auto r = q.ray_cast_all(time, Vec3(x, hi.y() + 20, z), Vec3(x, lo.y() - 60, z));
          if (r)
            for (const QueryHit& h : r->items)
              ground_hits += std::find(statics.begin(), statics.end(), h.id) != statics.end();
          out += describe(r);
        }
      return out;
    };
    auto run = [&](int territories, int anticipation) {
      std::vector<std::string> answers;
      std::vector<SensorStep> sensed;
      SimulationConfig config{.territories = territories, .buffer_capacity = 24};
      config.runtime.anticipation = anticipation;
      config.runtime.eager_bets = anticipation > 0;
      Simulation sim(s, config);
      SceneQuery q = sim.add_query();
      SensorReader sensors = sim.add_sensor_reader();
      sim.start(sim.time_of(kLast));
      std::thread reading([&] {
        for (int k = 0; k <= kLast; ++k)
          if (std::optional<SensorStep> st = sensors.read_step(k)) sensed.push_back(std::move(*st));
      });
      for (int k = 0; k <= kLast; k += kEach) answers.push_back(ask_down(q, sim.time_of(k)));
      reading.join();
      EXPECT_TRUE(sim.advance_to(sim.time_of(kLast)));
      answers.push_back(hash_hex(sim.state_hash()) + " sensors " + hash_hex(sensor_stream_hash(sensed)));
      std::size_t ground = 0;
      for (const SensorStep& st : sensed)
        for (const SensorOverlap& o : st.inside)
          ground += std::find(statics.begin(), statics.end(), o.body) != statics.end();
      answers.push_back("sensed the ground " + std::to_string(ground > 0));
      return answers;
    };
    const std::vector<std::string> one = run(1, 0);
    const std::size_t one_ground_hits = ground_hits;
    const std::vector<std::string> four = run(4, 8);
    EXPECT_GT(one_ground_hits, 40u) << name << ": the rays reach the level geometry";
    // On the heightfield the falling sensor reports the ground; city's
    // debris, and so the sensor, starts 20 m above the street mesh, out of
    // its reach in these 60 steps.
    if (std::string(name) == "terrain") EXPECT_EQ(one.back(), "sensed the ground 1") << name;
    ASSERT_EQ(four.size(), one.size());
    for (std::size_t i = 0; i < one.size(); ++i) EXPECT_EQ(four[i], one[i]) << name << ", answer " << i;
  }
}

}  // namespace
}  // namespace soda
