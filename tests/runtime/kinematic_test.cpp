// Kinematic bodies (docs/scene-format.md, "Kinematic bodies") keep
// decomposition invariance: the conveyor scene (pallets, a turntable and an
// elevator, kinematic, carrying boxes across territory borders) ends with
// the one-world hash for K = 1, 2, 4, 8 territories, every schedule,
// speculating (anticipation 8), under SyncTest, with cells ceded (churn) and
// with parking on and off. Every world holds every kinematic body, as every
// static, and writes its pose of each step from its path: the same bits in
// every world, owner of what it touches or not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "runtime/partitioned_test_util.h"
#include "soda/runtime/balance_log.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

constexpr int kSteps = 240;

const Scene& conveyor() {
  static const Scene s = test::scene("conveyor", 144);
  return s;
}

const BodyState& state_of(const std::vector<BodyState>& states, BodyId id) {
  for (const BodyState& b : states)
    if (b.id == id) return b;
  throw std::out_of_range("no body " + std::to_string(id));
}

class KinematicDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(KinematicDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  static const std::uint64_t ref = test::reference_hash(conveyor(), kSteps);
  const test::MatrixRun run = test::expect_one_world_hash(conveyor(), "conveyor 144", c, kSteps, ref);
  const WorldMetrics& t = run.total;
  if (c.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);
    EXPECT_GT(t.migrations_out, 0u);  // boxes carried across borders
    EXPECT_GT(t.manifolds_seeded, 0u);  // with their contact state, the pallet's contacts included
  }
  if (c.territories > 2) EXPECT_GT(t.merged_islands, 0u);  // stacks on a pallet over a border
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, KinematicDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

// Sequential and one thread per world (the matrix runs a pool of two).
TEST(KinematicDecomposition, EverySchedule) {
  const std::string ref = hash_hex(test::reference_hash(conveyor(), kSteps));
  const TerritoryMap map = make_partition("kmeans", conveyor(), 4, GridOptions{});
  for (Schedule schedule : {Schedule::Sequential, Schedule::ThreadPerWorld}) {
    PartitionedOptions o;
    o.schedule = schedule;
    o.runtime.anticipation = 8;
    o.runtime.parking = true;
    PartitionedWorld w(conveyor(), map, o);
    w.step(kSteps);
    EXPECT_EQ(hash_hex(w.state_hash()), ref) << "schedule " << int(schedule);
  }
}

// Cells ceded every 10 steps (churn) while speculating and under SyncTest:
// the boxes a pallet carries migrate with the cells, the pallet stays in
// every world.
TEST(KinematicDecomposition, ChurnSpeculatingUnderSyncTest) {
  const std::string ref = hash_hex(test::reference_hash(conveyor(), kSteps));
  for (int k : {2, 4}) {
    PartitionedWorld w(conveyor(), make_partition("kmeans", conveyor(), k, GridOptions{}), test::churn_options(7));
    w.step(kSteps);
    const BalanceTotals t = balance_totals(w.balance_log());
    std::printf("[ conveyor 144 %s, churn K=%d anticipation 8 sync-test 1 ] %lld bodies moved, %llu sync rollbacks; "
                "%s, one world %s\n",
                kPrecisionName, k, static_cast<long long>(t.bodies_moved),
                static_cast<unsigned long long>(w.sync_rollbacks()), hash_hex(w.state_hash()).c_str(), ref.c_str());
    EXPECT_GT(t.bodies_moved, 0);
    EXPECT_GT(w.sync_rollbacks(), 0u);
    EXPECT_EQ(hash_hex(w.state_hash()), ref) << "K=" << k;
  }
}

// The platforms are where their paths say, whatever they carry (never
// pushed), and they carry: boxes on the pallets travel metres along x, the
// elevator's rise 3 m.
TEST(Kinematic, PlatformsFollowTheirPathsAndCarryBoxes) {
  const Scene& s = conveyor();
  CanonicalWorld w(s);
  const int steps = 420;  // 7 s: the elevator is at the top
  for (int i = 0; i < steps; ++i) w.step();
  const std::vector<BodyState> states = w.body_states();
  for (const Body& b : s.bodies) {
    if (!b.kinematic) continue;
    const Pose p = kinematic_pose(b, internal_step_time(s.settings, steps));
    const btVector3 at = to_bt(p.position);
    const BodyState& st = state_of(states, b.id);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(st.origin[k], at[k]) << "platform " << b.id << " axis " << k;
  }
  double farthest = 0.0, highest = 0.0;
  for (const Body& b : s.bodies) {
    if (b.is_static) continue;
    const BodyState& st = state_of(states, b.id);
    farthest = std::max(farthest, std::abs(double(st.origin[0]) - b.position.x()));
    highest = std::max(highest, double(st.origin[1]) - b.position.y());
  }
  std::printf("[ conveyor 144 %s, %d steps ] boxes moved up to %.2f m along x and rose up to %.2f m\n", kPrecisionName,
              steps, farthest, highest);
  EXPECT_GT(farthest, 4.0);
  EXPECT_GT(highest, 2.5);
}

// What the elevator carries falls asleep while it rests and parks (parking
// on); the elevator starting to rise wakes it, parked or not: parking on
// and off end in the same state, and the boxes went up.
TEST(Kinematic, AMovingPlatformWakesWhatItCarriesParkedOrNot) {
  const Scene& s = conveyor();
  CanonicalWorld parked(s), awake(s);
  parked.set_parking(true);
  std::size_t most_parked = 0;
  for (int i = 0; i < 230; ++i) {  // the elevator rests for 240 steps
    parked.step();
    awake.step();
    most_parked = std::max(most_parked, parked.parked_count());
  }
  EXPECT_GT(most_parked, 0u);
  for (int i = 230; i < 420; ++i) parked.step(), awake.step();
  EXPECT_EQ(hash_hex(parked.state_hash(true)), hash_hex(awake.state_hash(true)));
  const BodyId elevator = 6;
  const Body* lift = nullptr;
  for (const Body& b : s.bodies)
    if (b.id == elevator) lift = &b;
  ASSERT_TRUE(lift && lift->kinematic);
  int risen = 0;
  const std::vector<BodyState> states = parked.body_states();
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    const Body& b = s.bodies[i];
    if (b.is_static || (b.id - 7) % 6 != 5) continue;  // the boxes dropped on the elevator
    if (state_of(states, b.id).origin[1] > b.position.y() + 2.5) ++risen;
  }
  std::printf("[ conveyor 144 %s ] %zu bodies parked at most while the elevator rested; %d of its boxes rose\n",
              kPrecisionName, most_parked, risen);
  EXPECT_GT(risen, 0);
}

// A world rebuilt from a snapshot (kinematic bodies in it, with their path)
// steps on exactly, as a partitioned run rebuilt from one.
TEST(Kinematic, SnapshotsCarryKinematicBodies) {
  const Scene& s = conveyor();
  CanonicalWorld whole(s);
  for (int i = 0; i < 100; ++i) whole.step();
  const WorldSnapshot snap = deserialize_snapshot(serialize(whole.snapshot()));
  CanonicalWorld rebuilt(snap);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedWorld part(snap, map, PartitionedOptions{});
  for (int i = 0; i < 100; ++i) whole.step(), rebuilt.step();
  part.step(100);
  EXPECT_EQ(hash_hex(rebuilt.state_hash(true)), hash_hex(whole.state_hash(true)));
  EXPECT_EQ(hash_hex(part.state_hash()), hash_hex(whole.state_hash()));
}

}  // namespace
}  // namespace soda
