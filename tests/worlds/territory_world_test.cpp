// The territory world alone: with one territory (no neighbours, no ghosts)
// its staged step is the canonical world's step; bodies outside the
// partitioned exactness contract are refused; a re-run that replays the
// islands of an old run (set_replay) gives what solving them gives.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/canonical_world.h"
#include "soda/worlds/territory_world.h"
#include "soda/worlds/world_snapshot.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

void step_alone(TerritoryWorld& w) {
  w.predict();
  w.apply_ghosts({});
  w.collide();
  w.build_islands();
  EXPECT_TRUE(w.border_fragments({}).empty());
  w.finish_islands();
  w.integrate();
  for (const auto& [n, batch] : w.migrate()) EXPECT_TRUE(batch.migrants.empty());
  w.absorb_migrants({});
}

std::uint64_t hash_of(const TerritoryWorld& w) {
  std::vector<BodyState> states = w.owned_states();
  for (const BodyState& s : w.static_states()) states.push_back(s);
  return state_hash(states);
}

TEST(TerritoryWorld, OneTerritoryStepsAsTheCanonicalWorld) {
  for (const char* name : {"cube-pile", "falling-cubes", "projectile"}) {
    const Scene s = test::scene(name, 200);
    CanonicalWorld reference(s);
    TerritoryWorld alone(s, 0, TerritoryMap());
    for (int i = 0; i < 300; ++i) {
      reference.step();
      step_alone(alone);
    }
    std::printf("[ %s %s ] canonical %s, one territory world %s, %zu asleep\n", name, kPrecisionName,
                hash_hex(reference.state_hash()).c_str(), hash_hex(hash_of(alone)).c_str(), alone.sleeping_count());
    EXPECT_EQ(hash_hex(hash_of(alone)), hash_hex(reference.state_hash()));
    EXPECT_EQ(alone.steps_done(), 300);
    EXPECT_EQ(alone.owned_count() + alone.static_count(), s.bodies.size());
    EXPECT_EQ(alone.ghost_count(), 0u);
    EXPECT_EQ(alone.sleeping_count(), reference.sleeping_count());
  }
}

// Parking in a territory world (#18, docs/skip.md): one territory world with
// parking against the canonical world without it, step by step; switched
// off mid-run every island comes back with its contacts; a world rebuilt
// from the snapshot of a parking world (parking taken over through
// share_pools_of) steps on identically.
TEST(TerritoryWorld, ParkingOnOffAndRebuiltAsTheCanonicalWorld) {
  const Scene s = test::scene("sleepers", 500);
  CanonicalWorld reference(s);
  TerritoryWorld parked(s, 0, TerritoryMap());
  parked.set_parking(true);
  EXPECT_GE(parked.parked_count(), 500u);  // the scene's sleepers, at once
  EXPECT_EQ(parked.owned_count() + parked.static_count(), s.bodies.size());
  for (int i = 0; i < 150; ++i) {
    reference.step();
    step_alone(parked);
    ASSERT_EQ(hash_hex(hash_of(parked)), hash_hex(reference.state_hash())) << "step " << i + 1;
  }
  ASSERT_GT(parked.parked_count(), 0u);
  EXPECT_LT(parked.bullet_object_count(), parked.owned_count() + parked.static_count());
  EXPECT_EQ(parked.sleeping_count(), reference.sleeping_count());
  const WorldSnapshot at150 = parked.part_snapshot();
  EXPECT_EQ(at150.manifolds.size(), reference.snapshot().manifolds.size());
  // Rebuilt from the parking world's state (statics added back), taking its setting.
  WorldSnapshot whole = at150;
  for (const BodySnapshot& b : parked.static_snapshots()) whole.bodies.push_back(b);
  std::sort(whole.bodies.begin(), whole.bodies.end(),
            [](const BodySnapshot& a, const BodySnapshot& b) { return a.description.id < b.description.id; });
  TerritoryWorld rebuilt(whole, 0, TerritoryMap(), -1, &parked);
  EXPECT_TRUE(rebuilt.parking());
  parked.set_parking(false);
  EXPECT_EQ(parked.parked_count(), 0u);
  EXPECT_EQ(parked.bullet_object_count(), parked.owned_count() + parked.static_count());
  EXPECT_EQ(serialize(parked.part_snapshot()), serialize(at150));
  for (int i = 0; i < 100; ++i) {
    reference.step();
    step_alone(parked);
    step_alone(rebuilt);
  }
  EXPECT_EQ(hash_hex(hash_of(parked)), hash_hex(reference.state_hash()));
  EXPECT_EQ(hash_hex(hash_of(rebuilt)), hash_hex(reference.state_hash()));
  EXPECT_GT(rebuilt.parked_count(), 0u);  // parked again at its steps' ends
}

// Rollback and Propagate at the level of one world. An old run records, at
// every step, its state at both ends and the islands it solved; a world
// rebuilt from its state at step kFrom replays it.
struct OldRun {
  std::vector<WorldSnapshot> states;    // at kFrom, kFrom + 1, ...
  std::vector<LocalIslands> islands;    // solved in step kFrom, kFrom + 1, ...
  std::vector<BodySnapshot> statics;
};
constexpr int kFrom = 40, kSteps = 30;

OldRun record(const Scene& s) {
  OldRun old;
  TerritoryWorld w(s, 0, TerritoryMap());
  for (int i = 0; i < kFrom; ++i) step_alone(w);
  old.statics = w.static_snapshots();
  old.states.push_back(w.part_snapshot());
  for (int i = 0; i < kSteps; ++i) {
    step_alone(w);
    old.islands.push_back(w.local_islands());
    old.states.push_back(w.part_snapshot());
  }
  return old;
}

std::unique_ptr<TerritoryWorld> rebuilt(const OldRun& old) {
  WorldSnapshot whole = old.states.front();
  whole.bodies.insert(whole.bodies.end(), old.statics.begin(), old.statics.end());
  std::sort(whole.bodies.begin(), whole.bodies.end(),
            [](const BodySnapshot& a, const BodySnapshot& b) { return a.description.id < b.description.id; });
  return std::make_unique<TerritoryWorld>(whole, 0, TerritoryMap());
}

// The old run replayed with one body pushed at step kFrom: only islands
// holding bodies whose state departs from the old run's are solved, and
// the result is that of a plain re-run (no replay) with the same push.
TEST(TerritoryWorld, ReplayedIslandsGiveWhatSolvingGives) {
  for (const char* name : {"cube-pile", "falling-cubes"}) {
    const Scene s = test::scene(name, 200);
    const OldRun old = record(s);
    const BodyId pushed = old.states.front().bodies[old.states.front().bodies.size() / 2].description.id;
    for (bool push : {false, true})
      for (bool verify : {false, true}) {
        auto replayed = rebuilt(old);
        auto plain = rebuilt(old);
        if (push) {
          ASSERT_TRUE(replayed->apply_impulse(pushed, Vec3(0.0, 0.0, 5.0)));
          ASSERT_TRUE(plain->apply_impulse(pushed, Vec3(0.0, 0.0, 5.0)));
        }
        std::size_t solved = 0, kept = 0, first_step_solved = 0;
        for (int i = 0; i < kSteps; ++i) {
          replayed->set_replay(StepReplay{&old.states[static_cast<std::size_t>(i)],
                                          &old.states[static_cast<std::size_t>(i) + 1],
                                          &old.islands[static_cast<std::size_t>(i)], false, verify});
          step_alone(*replayed);
          step_alone(*plain);
          const std::size_t r = replayed->counters().bodies_replayed;
          kept += r;
          solved += replayed->owned_count() - r;
          if (i == 0) first_step_solved = replayed->owned_count() - r;
        }
        std::printf("[ replay %s%s%s ] %zu bodies solved, %zu replayed (first step: %zu solved of %zu)\n", name,
                    push ? ", pushed" : "", verify ? ", verified" : "", solved, kept, first_step_solved,
                    replayed->owned_count());
        EXPECT_EQ(hash_hex(hash_of(*replayed)), hash_hex(hash_of(*plain))) << name << " push " << push;
        EXPECT_EQ(serialize(replayed->part_snapshot()), serialize(plain->part_snapshot())) << name;
        if (!push) {
          EXPECT_EQ(solved, 0u) << name << ": nothing changed, every island is replayed";
        } else {
          EXPECT_GT(first_step_solved, 0u) << name << ": the pushed body's island is solved";
          EXPECT_LT(first_step_solved, replayed->owned_count()) << name << ": the others are replayed";
        }
      }
  }
}

// A step interrupted after its islands were solved (a rollback in the
// middle of a step): its solved_state replays in place of the solve.
TEST(TerritoryWorld, MidStepReplayGivesWhatSolvingGives) {
  const Scene s = test::scene("cube-pile", 200);
  const OldRun old = record(s);
  auto interrupted = rebuilt(old);
  interrupted->predict();
  interrupted->apply_ghosts({});
  interrupted->collide();
  interrupted->build_islands();
  LocalIslands islands;
  WorldSnapshot solved;
  ASSERT_TRUE(interrupted->solved_state(islands, solved));
  auto replayed = rebuilt(old);
  replayed->set_replay(StepReplay{&old.states[0], &solved, &islands, true, false});
  step_alone(*replayed);
  EXPECT_EQ(replayed->counters().bodies_replayed, replayed->owned_count());
  EXPECT_EQ(serialize(replayed->part_snapshot()), serialize(old.states[1]));
}

// Bodies of any size (docs/determinism.md): a 4 m cube is taken, and its
// manifolds break at sqrt(2) * gContactBreakingThreshold, while a unit
// cube's keep Bullet's own threshold (its bounding radius * 0.02) bit for bit.
TEST(TerritoryWorld, TakesLargeBodiesWithTheCappedBreakingThreshold) {
  Scene s = test::scene("falling-cubes", 3);
  s.bodies.back().shape = Shape::box(Vec3(2.0, 2.0, 2.0));  // a 4 m cube: radius 3.46 m
  EXPECT_NO_THROW(TerritoryWorld(s, 0, TerritoryMap()));
  CanonicalWorld w(s);
  for (int i = 0; i < 200; ++i) w.step();
  btDispatcher& d = *w.bullet().getDispatcher();
  const btScalar capped = btScalar(std::sqrt(2.0)) * gContactBreakingThreshold;
  int large = 0;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    const btScalar bullet =
        btMin(m->getBody0()->getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold),
              m->getBody1()->getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold));
    EXPECT_EQ(m->getContactBreakingThreshold(), btMin(bullet, capped));  // unit cubes: Bullet's own
    if (bullet > capped) ++large;
  }
  std::printf("[ thresholds ] %d of %d manifolds capped (the 4 m cube's)\n", large, d.getNumManifolds());
  EXPECT_GT(large, 0);
}

}  // namespace
}  // namespace soda
