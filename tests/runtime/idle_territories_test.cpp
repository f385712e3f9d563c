// Idle territories (#18, docs/skip.md): a world whose bodies all sleep
// settled skips its Bullet stages at steps no neighbour sends it a ghost
// for. Exact: the state hash is the same with the skip on and off, and
// equals the one-territory run's, in lockstep, with speculation
// (anticipation 8) and under SyncTest; worlds woken by a neighbour's body
// or by a user input run their steps as before. Each case also checks that
// the skip happened (idle steps counted), so the comparisons are not
// vacuous. Small scenes (a few hundred bodies, 120 steps).
#include <cstdio>
#include <tuple>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/run.h"
#include "soda/worlds/territory_world.h"

namespace soda {
namespace {

constexpr int kSteps = 120;

std::uint64_t idle_steps(const RunResult& r) {
  std::uint64_t n = 0;
  for (const WorldMetrics& m : r.world_metrics) n += m.idle_steps;
  return n;
}

std::uint64_t halos_culled(const RunResult& r) {
  std::uint64_t n = 0;
  for (const WorldMetrics& m : r.world_metrics) n += m.halos_culled;
  return n;
}

// Border culling off while in scope (it is on by default).
struct NoBorderCulling {
  NoBorderCulling() { set_border_culling(false); }
  ~NoBorderCulling() { set_border_culling(true); }
  NoBorderCulling(const NoBorderCulling&) = delete;
  NoBorderCulling& operator=(const NoBorderCulling&) = delete;
};

struct Case {
  const char* name;
  int anticipation;
  int sync_test;
};

// idle-territories with one more cube thrown from region 0 towards region
// 1 (20.6 m wide regions, region 0's pile at x in [-73.9, -70.3], region
// 1's sleepers at x in [-53, -50], rows along z 1.5 m apart from -5.25):
// world 1 idles until the cube's halo reaches it (its ghosts wake it), the
// cube lands on its sleepers and wakes them.
constexpr int kPerRegion = 24;
Scene thrown_into_sleepers() {
  Scene s = test::scene("idle-territories", kPerRegion);
  Body cube = s.bodies.back();
  cube.id = 8 * kPerRegion + 1;
  cube.asleep = false;
  cube.position = Vec3(-67.2, 2.0, 0.75);
  cube.linear_velocity = Vec3(17.0, 4.0, 0.0);
  s.bodies.push_back(cube);
  return s;
}

RunConfig config(int territories, const std::string& partition, const Case& c, bool idle) {
  RunConfig r;
  r.steps = kSteps;
  r.progress_seconds = 0;
  r.territories = territories;
  r.partition = partition;
  r.threads = 1;
  r.serialise = true;
  r.runtime.anticipation = c.anticipation;
  r.sync_test = c.sync_test;
  r.runtime.idle_territories = idle;
  return r;
}

class IdleTerritories : public ::testing::TestWithParam<Case> {};

// The one-territory run of `s`, then eight territories with the skip on and
// off, both checked against it.
struct OneOnOff {
  RunResult reference, on, off;
};
OneOnOff one_on_off(const Scene& s, const Case& c) {
  RunConfig one;
  one.steps = kSteps;
  one.progress_seconds = 0;
  OneOnOff r{run_scene(s, one), run_scene(s, config(8, "grid:8x1x1", c, true)),
             run_scene(s, config(8, "grid:8x1x1", c, false))};
  EXPECT_EQ(hash_hex(r.on.state_hash), hash_hex(r.reference.state_hash));
  EXPECT_EQ(hash_hex(r.off.state_hash), hash_hex(r.reference.state_hash));
  return r;
}

// Activity in one of eight territories: the seven others idle from the
// first step to the last.
TEST_P(IdleTerritories, EightTerritoriesActivityInOneSameHashOnOffAndAsOne) {
  const Case c = GetParam();
  const Scene s = test::scene("idle-territories", kPerRegion);
  const auto [reference, on, off] = one_on_off(s, c);
  EXPECT_EQ(idle_steps(off), 0u);
  // Worlds 1..7 idle at every step (re-runs of SyncTest and rollbacks add more).
  // (The first step is a full one: halos unknown.)
  EXPECT_GE(idle_steps(on), 7u * (kSteps - 1));
  EXPECT_EQ(on.world_metrics.at(0).idle_steps, 0u);
  std::printf("[ %s ] %s, %llu idle steps\n", c.name, hash_hex(on.state_hash).c_str(),
              static_cast<unsigned long long>(idle_steps(on)));
}

// A body flies from a busy territory into an idle one and wakes its sleepers.
TEST_P(IdleTerritories, AGhostWakesAnIdleTerritory) {
  const Case c = GetParam();
  const Scene s = thrown_into_sleepers();
  const auto [reference, on, off] = one_on_off(s, c);
  EXPECT_GT(on.world_metrics.at(1).idle_steps, 0u);
  EXPECT_LT(on.world_metrics.at(1).idle_steps, static_cast<std::uint64_t>(kSteps - 1)) << "world 1 was never woken";
  std::printf("[ %s ] %s, idle steps of world 1: %llu, asleep at the end %zu\n", c.name,
              hash_hex(on.state_hash).c_str(), static_cast<unsigned long long>(on.world_metrics.at(1).idle_steps),
              reference.sleeping_bodies);
}

// A user input (an impulse on a sleeper of an idle territory) wakes it.
TEST_P(IdleTerritories, AnInputWakesAnIdleTerritory) {
  const Case c = GetParam();
  const Scene s = test::scene("idle-territories", kPerRegion);
  UserInput push;
  push.kind = UserInput::Kind::ApplyImpulse;
  push.step = 40;
  push.id = s.bodies.back().id;  // a sleeper of the last region
  push.linear = Vec3(0.0, 8.0, 3.0);
  RunConfig one;
  one.steps = kSteps;
  one.progress_seconds = 0;
  one.inputs = std::vector<UserInput>{push};
  RunConfig on = config(8, "grid:8x1x1", c, true);
  on.inputs = one.inputs;
  RunConfig off = on;
  off.runtime.idle_territories = false;
  const RunResult reference = run_scene(s, one);
  const RunResult r_on = run_scene(s, on);
  const RunResult r_off = run_scene(s, off);
  EXPECT_EQ(hash_hex(r_on.state_hash), hash_hex(reference.state_hash));
  EXPECT_EQ(hash_hex(r_off.state_hash), hash_hex(reference.state_hash));
  EXPECT_GT(r_on.world_metrics.at(7).idle_steps, 0u);
  EXPECT_LT(r_on.world_metrics.at(7).idle_steps, static_cast<std::uint64_t>(kSteps)) << "world 7 was never woken";
}

// Border culling (docs/skip.md): the cube thrown from region 0 crosses the
// border 0|1 (it leaves its block of owned cells, is looked up, ghosted and
// migrates), and falling-cubes 150 cut 2x1x2 (not under SyncTest) has bodies
// crossing borders and piling on them. Same hash with culling on and off, and as one territory;
// culling happened (and not when off), so the comparison is not vacuous.
TEST_P(IdleTerritories, BorderCullingSameHashOnOffAndAsOne) {
  const Case c = GetParam();
  std::vector<std::tuple<Scene, int, const char*>> cases{{thrown_into_sleepers(), 8, "grid:8x1x1"}};
  // SyncTest restores every world at every step: falling-cubes there would
  // take seconds; the thrown cube covers it (culled, looked up, ghosted).
  if (c.sync_test == 0) cases.emplace_back(test::scene("falling-cubes", 150), 4, "grid:2x1x2");
  for (const auto& [s, territories, partition] : cases) {
    RunConfig one;
    one.steps = kSteps;
    one.progress_seconds = 0;
    const RunResult reference = run_scene(s, one);
    const RunResult on = run_scene(s, config(territories, partition, c, true));
    RunResult off;
    {
      NoBorderCulling no;
      off = run_scene(s, config(territories, partition, c, true));
    }
    EXPECT_EQ(hash_hex(on.state_hash), hash_hex(reference.state_hash)) << s.name;
    EXPECT_EQ(hash_hex(off.state_hash), hash_hex(reference.state_hash)) << s.name;
    EXPECT_GT(halos_culled(on), 0u) << s.name;
    EXPECT_EQ(halos_culled(off), 0u) << s.name;
    std::uint64_t ghosts = 0, migrations = 0;
    for (const WorldMetrics& m : on.world_metrics) ghosts += m.ghosts_sent, migrations += m.migrations_out;
    EXPECT_GT(ghosts, 0u) << s.name << ": no border traffic";
    std::printf("[ %s ] %s: %s, %llu halos culled, %llu ghosts, %llu migrations\n", c.name, s.name.c_str(),
                hash_hex(on.state_hash).c_str(), static_cast<unsigned long long>(halos_culled(on)),
                static_cast<unsigned long long>(ghosts), static_cast<unsigned long long>(migrations));
  }
}

INSTANTIATE_TEST_SUITE_P(Runtime, IdleTerritories,
                         ::testing::Values(Case{"lockstep", 0, 0}, Case{"anticipation8", 8, 0},
                                           Case{"synctest2", 0, 2}),
                         [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace soda
