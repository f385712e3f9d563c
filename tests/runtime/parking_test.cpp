// Parking of sleeping islands (#18, worlds/src/parking.h, docs/skip.md): the
// state is the same with parking on and off at every step, in the canonical
// world and in territory worlds, and the partitioned runs (N territories vs
// 1, speculation, SyncTest, load balancing) end on the one-territory hash
// with parking on and off. Small sleepers scenes: sleepers woken by falling
// bodies, woken islands parked again.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/run.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

constexpr int kSleepers = 2000;  // 20 active cubes
constexpr int kSteps = 300;      // they land, wake sleepers, and the woken ones fall asleep again

// Woken islands' bodies are merged into the world's id-sorted dynamic bodies
// (canonical_dynamics_world.cpp): every dynamic body in Bullet's world has
// user index 2 = its position among them by id, which islands are built on.
bool positions_follow_ids(CanonicalWorld& world) {
  std::vector<std::pair<int, int>> id_position;
  const btCollisionObjectArray& objects = world.bullet().getCollisionObjectArray();
  for (int i = 0; i < objects.size(); ++i)
    if (!objects[i]->isStaticOrKinematicObject())
      id_position.emplace_back(objects[i]->getUserIndex(), objects[i]->getUserIndex2());
  std::sort(id_position.begin(), id_position.end());
  for (std::size_t i = 0; i < id_position.size(); ++i)
    if (id_position[i].second != static_cast<int>(i)) return false;
  return true;
}

// Step by step, parking on and off: bodies, contacts and snapshots equal.
TEST(Parking, EveryStepEqualsTheWorldWithoutParking) {
  const Scene s = test::scene("sleepers", kSleepers);
  CanonicalWorld off(s);
  CanonicalWorld on(s);
  on.set_parking(true);
  // The scene's sleepers are settled when built: parked before the first step.
  EXPECT_EQ(on.parked_count(), static_cast<std::size_t>(kSleepers));
  EXPECT_EQ(hash_hex(on.state_hash(true)), hash_hex(off.state_hash(true)));
  EXPECT_EQ(serialize(on.snapshot()), serialize(off.snapshot()));
  std::size_t most_parked = 0, fewest_parked_after_most = 0;
  bool woke = false;
  for (int step = 1; step <= kSteps; ++step) {
    off.step();
    on.step();
    ASSERT_EQ(hash_hex(on.state_hash(true)), hash_hex(off.state_hash(true))) << "step " << step;
    ASSERT_TRUE(positions_follow_ids(on)) << "step " << step;
    if (on.parked_count() > most_parked) most_parked = fewest_parked_after_most = on.parked_count();
    if (on.parked_count() < fewest_parked_after_most) {
      fewest_parked_after_most = on.parked_count();
      woke = true;
    }
  }
  EXPECT_EQ(on.snapshot().manifolds.size(), off.snapshot().manifolds.size());
  EXPECT_EQ(serialize(on.snapshot()), serialize(off.snapshot()));
  // The sleepers were parked, some were woken (unparked) by falling cubes.
  EXPECT_GE(most_parked, static_cast<std::size_t>(kSleepers) - 100);
  EXPECT_TRUE(woke);
  EXPECT_LT(on.last_step_stats().islands, off.last_step_stats().islands);
  std::printf("[ parking ] %d sleepers, %d steps: at most %zu parked, %zu at the end; %s\n", kSleepers, kSteps,
              most_parked, on.parked_count(), hash_hex(on.state_hash(true)).c_str());
}

// Switching parking off puts every island back, contacts included; a world
// restored from a snapshot of a parking world steps on identically.
TEST(Parking, OffAndRestoreContinueExactly) {
  const Scene s = test::scene("sleepers", 500);
  CanonicalWorld reference(s);
  CanonicalWorld toggled(s);
  toggled.set_parking(true);
  for (int step = 0; step < 150; ++step) reference.step(), toggled.step();
  ASSERT_GT(toggled.parked_count(), 0u);
  CanonicalWorld restored(toggled.snapshot());
  restored.set_parking(true);
  toggled.set_parking(false);
  EXPECT_EQ(toggled.parked_count(), 0u);
  EXPECT_EQ(hash_hex(toggled.state_hash(true)), hash_hex(reference.state_hash(true)));
  for (int step = 0; step < 100; ++step) reference.step(), toggled.step(), restored.step();
  EXPECT_EQ(hash_hex(toggled.state_hash(true)), hash_hex(reference.state_hash(true)));
  EXPECT_EQ(hash_hex(restored.state_hash(true)), hash_hex(reference.state_hash(true)));
}

// A fast body (docs/ccd.md: swept, speculative contacts) shot into a row of
// parked sleepers: its AABB covers its sweep, so the wake rule brings the
// sleeper it would hit back before the broadphase pass, and the CCD contact
// stops it exactly as without parking.
TEST(Parking, AFastBodyIsStoppedByAParkedSleeperAsWithoutParking) {
  Scene s = test::scene("sleepers", 400);  // sleepers 1.5 m apart, x and z in [-14.25, 14.25]
  BodyId next = 0;
  for (const Body& b : s.bodies) next = std::max(next, b.id + 1);
  Body bullet;
  bullet.id = next;
  bullet.shape = Shape::sphere(0.05);
  bullet.mass = 0.1;
  bullet.position = Vec3(-20.0, 0.5, 0.75);  // the row of sleepers at z = 0.75
  bullet.linear_velocity = Vec3(200.0, 0.0, 0.0);  // 3.3 m per step, 0.05 m radius: a fast body
  s.bodies.push_back(bullet);
  CanonicalWorld off(s);
  CanonicalWorld on(s);
  on.set_parking(true);
  ASSERT_GE(on.parked_count(), 400u);
  for (int step = 1; step <= 60; ++step) {
    off.step();
    on.step();
    ASSERT_EQ(hash_hex(on.state_hash(true)), hash_hex(off.state_hash(true))) << "step " << step;
    ASSERT_TRUE(positions_follow_ids(on)) << "step " << step;
  }
  // It hits the row's first sleepers and pushes them (0.1 kg at 200 m/s on
  // 1 kg cubes), ending in the field's first half; tunnelling through all
  // twenty sleepers it would be at x = -20 + 200 m/s * 1 s = 180 m.
  for (const BodyState& b : on.body_states())
    if (b.id == bullet.id) {
      EXPECT_LT(b.origin[0], btScalar(0.0)) << "the bullet went through the sleepers";
      EXPECT_GT(b.origin[0], btScalar(-15.0)) << "the bullet never reached the sleepers";
    }
}

// The sleepers the active bodies never reach change nothing: the scene
// without them gives every other body the same bits (what `soda bench
// sleepers`' soda-near-only run relies on: the same activity, docs/skip.md).
TEST(Parking, FarSleepersChangeNothing) {
  const Scene full = test::scene("sleepers", kSleepers);  // 20 active cubes within 1 m of x = z = 0
  constexpr double kNear = 12.0;
  Scene near = full;
  near.bodies.clear();
  for (const Body& b : full.bodies)
    if (!b.asleep || (std::abs(b.position.x()) <= kNear && std::abs(b.position.z()) <= kNear))
      near.bodies.push_back(b);
  ASSERT_LT(near.bodies.size() + 1500, full.bodies.size());
  CanonicalWorld a(full), b(near);
  a.set_parking(true);
  b.set_parking(true);
  for (int step = 0; step < kSteps; ++step) a.step(), b.step();
  std::vector<BodyState> common;
  for (const BodyState& s : a.body_states())
    for (const Body& n : near.bodies)
      if (n.id == s.id) common.push_back(s);
  ASSERT_EQ(common.size(), near.bodies.size());
  EXPECT_EQ(hash_hex(state_hash(common)), hash_hex(b.state_hash()));
  // Sleepers were moved (the comparison is not trivial); the far ones all sleep.
  int moved = 0;
  for (const BodyState& s : b.body_states())
    for (const Body& n : near.bodies)
      if (n.id == s.id && n.asleep && std::abs(double(s.origin[0]) - n.position.x()) > 1e-3) ++moved;
  EXPECT_GT(moved, 0);
  EXPECT_EQ(a.sleeping_count() - b.sleeping_count(), full.bodies.size() - near.bodies.size());
  std::printf("[ far sleepers ] %zu of %zu bodies kept, %d sleepers moved: %s\n", near.bodies.size(),
              full.bodies.size(), moved, hash_hex(b.state_hash()).c_str());
}

// --- territory worlds --------------------------------------------------------

std::size_t parked_in(const PartitionedWorld& world) {
  std::size_t n = 0;
  for (WorldId w = 0; w < world.world_count(); ++w) n += world.world(w).parked_count();
  return n;
}

// Territory worlds park too: 2 and 4 territories, step by step against the
// same worlds with parking off (state hash every step, the whole scene's
// snapshot with its contacts every 10 steps). The sleepers inside each
// world's cells are parked when the worlds are built; the falling cubes wake
// some (they land across the borders) and the woken ones are parked again.
TEST(TerritoryParking, EveryStepEqualsTheWorldsWithoutParking) {
  const Scene s = test::scene("sleepers", kSleepers);
  for (const char* partition : {"grid:2x1x1", "grid:2x1x2"}) {
    const int k = std::string(partition) == "grid:2x1x1" ? 2 : 4;
    const TerritoryMap map = make_partition(partition, s, k, GridOptions{});
    PartitionedOptions off_options;
    off_options.runtime.parking = false;
    PartitionedWorld on(s, map, PartitionedOptions{});
    PartitionedWorld off(s, map, off_options);
    const std::size_t built = parked_in(on);
    EXPECT_GT(built, static_cast<std::size_t>(kSleepers) * 3 / 4) << partition;
    EXPECT_EQ(parked_in(off), 0u);
    std::size_t most = built, fewest_after_most = built;
    bool woke = false, parked_again = false;
    for (int step = 1; step <= kSteps; ++step) {
      on.step(1);
      off.step(1);
      ASSERT_EQ(hash_hex(on.state_hash()), hash_hex(off.state_hash())) << partition << ", step " << step;
      if (step % 10 == 0) {
        ASSERT_EQ(serialize(on.snapshot()), serialize(off.snapshot())) << partition << ", step " << step;
      }
      const std::size_t parked = parked_in(on);
      if (parked < fewest_after_most) fewest_after_most = parked, woke = true;
      if (woke && parked > fewest_after_most) parked_again = true;
      most = std::max(most, parked);
    }
    EXPECT_TRUE(woke) << partition << ": no parked island was woken";
    EXPECT_TRUE(parked_again) << partition << ": no woken island was parked again";
    std::size_t in_bullet_on = 0, in_bullet_off = 0;
    for (WorldId w = 0; w < k; ++w) {
      in_bullet_on += on.world(w).bullet_object_count();
      in_bullet_off += off.world(w).bullet_object_count();
    }
    EXPECT_LT(in_bullet_on + static_cast<std::size_t>(kSleepers) / 2, in_bullet_off) << partition;
    std::printf("[ territory parking %s ] %zu parked when built, at most %zu, %zu at the end; %s\n", partition,
                built, most, parked_in(on), hash_hex(on.state_hash()).c_str());
  }
}

// Inputs name parked bodies: a push and a velocity wake the body's island
// (and its contacts) at the step boundary they apply at; a removal takes a
// parked body out with its contact state. Same hash as without parking.
TEST(TerritoryParking, InputsToParkedBodiesAsWithoutParking) {
  const Scene s = test::scene("sleepers", 600);
  // Sleepers far from the falling cubes (x, z in [-18, 18], cubes near 0).
  std::vector<BodyId> far;
  for (const Body& b : s.bodies)
    if (b.asleep && std::abs(b.position.x()) > 10.0 && std::abs(b.position.z()) > 10.0) far.push_back(b.id);
  ASSERT_GE(far.size(), 3u);
  auto input = [](UserInput::Kind kind, std::int64_t step, BodyId id, Vec3 linear, Vec3 angular) {
    UserInput u;
    u.kind = kind;
    u.step = step;
    u.sequence = static_cast<std::uint64_t>(step);
    u.id = id;
    u.linear = linear;
    u.angular = angular;
    return u;
  };
  const std::vector<UserInput> inputs = {
      input(UserInput::Kind::ApplyImpulse, 40, far[0], Vec3(3.0, 2.0, 0.0), Vec3::Zero()),
      input(UserInput::Kind::SetVelocity, 60, far[1], Vec3(0.0, 4.0, 1.0), Vec3(0.0, 2.0, 0.0)),
      input(UserInput::Kind::RemoveBody, 80, far[2], Vec3::Zero(), Vec3::Zero())};
  const TerritoryMap map = make_partition("grid:2x1x1", s, 2, GridOptions{});
  PartitionedOptions on_options, off_options;
  on_options.inputs = inputs;
  off_options.inputs = inputs;
  off_options.runtime.parking = false;
  PartitionedWorld on(s, map, on_options);
  PartitionedWorld off(s, map, off_options);
  const std::size_t built = parked_in(on);
  for (int step = 1; step <= 150; ++step) {
    on.step(1);
    off.step(1);
    ASSERT_EQ(hash_hex(on.state_hash()), hash_hex(off.state_hash())) << "step " << step;
  }
  EXPECT_EQ(serialize(on.snapshot()), serialize(off.snapshot()));
  EXPECT_GT(built, 0u);
  // The pushed sleepers moved.
  const WorldSnapshot end = on.snapshot();
  for (BodyId id : {far[0], far[1]})
    for (const BodySnapshot& b : end.bodies)
      if (b.description.id == id) {
        const Body* start = nullptr;
        for (const Body& x : s.bodies)
          if (x.id == id) start = &x;
        ASSERT_NE(start, nullptr);
        EXPECT_GT(std::abs(double(b.state.origin[0]) - start->position.x()) +
                      std::abs(double(b.state.origin[1]) - start->position.y()),
                  0.1)
            << "body " << id << " did not move";
      }
  for (const BodySnapshot& b : end.bodies) EXPECT_NE(b.description.id, far[2]);
}

struct Case {
  int territories;
  int anticipation;
  int sync_test;
  bool churn;  // load balancing moves cells (worlds rebuilt mid-run)
};

class ParkingVsPartitioned : public ::testing::TestWithParam<Case> {};

// The one-territory run with parking (the default of run_scene) against
// K territories with parking on (the default) and off, with speculation,
// SyncTest or churn's cessions.
TEST_P(ParkingVsPartitioned, SameHashAsOneTerritoryWithParking) {
  const Case c = GetParam();
  const Scene s = test::scene("sleepers", kSleepers);
  RunConfig one;
  one.steps = kSteps;
  one.progress_seconds = 0;
  RunConfig no_parking = one;
  no_parking.runtime.parking = false;
  RunConfig k = one;
  k.territories = c.territories;
  k.threads = 1;
  k.runtime.anticipation = c.anticipation;
  k.sync_test = c.sync_test;
  if (c.churn) {
    k.runtime.balance.policy = "churn";
    k.runtime.balance.period = 20;
  }
  RunConfig k_unparked = k;
  k_unparked.runtime.parking = false;
  const RunResult parked = run_scene(s, one);
  const RunResult unparked = run_scene(s, no_parking);
  const RunResult partitioned = run_scene(s, k);
  const RunResult partitioned_unparked = run_scene(s, k_unparked);
  EXPECT_EQ(hash_hex(parked.state_hash), hash_hex(unparked.state_hash));
  EXPECT_EQ(hash_hex(partitioned.state_hash), hash_hex(parked.state_hash));
  EXPECT_EQ(hash_hex(partitioned_unparked.state_hash), hash_hex(parked.state_hash));
  std::printf("[ parking vs K=%d, anticipation %d, sync-test %d%s ] %s\n", c.territories, c.anticipation,
              c.sync_test, c.churn ? ", churn" : "", hash_hex(parked.state_hash).c_str());
}

INSTANTIATE_TEST_SUITE_P(Runtime, ParkingVsPartitioned,
                         ::testing::Values(Case{4, 8, 0, false}, Case{2, 0, 2, false}, Case{3, 8, 1, false},
                                           Case{4, 0, 0, true}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return "K" + std::to_string(info.param.territories) + "_anticipation" +
                                  std::to_string(info.param.anticipation) + "_sync" +
                                  std::to_string(info.param.sync_test) + (info.param.churn ? "_churn" : "");
                         });

}  // namespace
}  // namespace soda
