// Collision filtering (Body::collision_group, collision_mask;
// docs/scene-format.md, "Collision filtering") keeps decomposition
// invariance: a pile whose boxes fall in three groups, each masking out the
// next one, so that about a third of the touching pairs pass through each
// other, ends with the one-world hash for K = 1, 2, 4, 8 territories,
// speculating (anticipation 8), under SyncTest and with parking on and off.
// The filter decides: the same pile unfiltered ends elsewhere, and so does a
// pile whose filter reaches only the worlds that own the bodies (a ghost
// without it would touch what its owner does not). Filters changed by input
// at a step boundary keep it too, on every schedule, under churn and the
// fuzzer.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "driver/testing_hooks.h"
#include "runtime/partitioned_test_util.h"
#include "soda/runtime/balance_log.h"
#include "soda/runtime/simulation.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"

namespace soda {
namespace {

constexpr int kSteps = 200;

// Dynamic body i: group bit 1 + i % 3, every mask bit but the next group's:
// a and b touch unless a % 3 and b % 3 are next to each other (mod 3).
// Statics keep the default filter: everything lands on the ground.
Scene filtered(Scene s) {
  for (Body& b : s.bodies) {
    if (b.is_static) continue;
    b.collision_group = 2u << (b.id % 3);
    b.collision_mask = ~(2u << ((b.id + 1) % 3));
  }
  return s;
}

const Scene& pile() {
  static const Scene s = filtered(test::scene("cube-pile", 150));
  return s;
}

std::uint64_t reference(bool parking) { return test::reference_hash(pile(), kSteps, parking); }

class FilterDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(FilterDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  static const std::uint64_t ref = reference(false);
  const test::MatrixRun run = test::expect_one_world_hash(pile(), "filtered cube-pile 150", c, kSteps, ref);
  const WorldMetrics& t = run.total;
  if (c.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);
    EXPECT_GT(t.migrations_out, 0u);
  }
  if (c.territories >= 8) EXPECT_GT(t.merged_islands, 0u);  // kmeans on 2 and 4 cuts no filtered island
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, FilterDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

// The one world with parking on gives the same hash as with it off; the
// filter changes the result (the pile unfiltered ends elsewhere).
TEST(FilterDecomposition, ParkingDoesNotMatterAndTheFilterDoes) {
  const std::uint64_t off = reference(false), on = reference(true);
  CanonicalWorld plain(test::scene("cube-pile", 150));
  for (int i = 0; i < kSteps; ++i) plain.step();
  std::printf("[ filtered cube-pile 150 %s ] one world: parking off %s, on %s; unfiltered %s\n", kPrecisionName,
              hash_hex(off).c_str(), hash_hex(on).c_str(), hash_hex(plain.state_hash()).c_str());
  EXPECT_EQ(hash_hex(on), hash_hex(off));
  EXPECT_NE(hash_hex(plain.state_hash()), hash_hex(off));
}

// Two boxes dropped one onto the other: with filters that keep them apart
// the upper one falls through the lower one to the ground, in the one world,
// in two territories split between them and in stock Bullet; with the
// default filter it rests on top.
Scene two_boxes(bool apart) {
  Scene s;
  s.name = "two-boxes";
  Body ground;
  ground.id = 0;
  ground.is_static = true;
  ground.shape = Shape::box(Vec3(10, 0.5, 10));
  ground.position = Vec3(0, -0.5, 0);
  s.bodies.push_back(ground);
  for (BodyId id : {BodyId{1}, BodyId{2}}) {
    Body b;
    b.id = id;
    b.shape = Shape::box(Vec3(0.5, 0.5, 0.5));
    b.position = Vec3(0.3, id == 1 ? 0.5 : 1.6, 0.0);
    if (apart) {
      b.collision_group = id == 1 ? 2u : 4u;
      b.collision_mask = id == 1 ? ~4u : ~2u;
    }
    s.bodies.push_back(b);
  }
  return s;
}

double upper_height(const std::vector<BodyState>& states) {
  for (const BodyState& b : states)
    if (b.id == 2) return double(b.origin[1]);
  return -1e9;
}

TEST(FilterDecomposition, FilteredBoxesPassThroughEachOtherEverywhere) {
  for (bool apart : {false, true}) {
    const Scene s = two_boxes(apart);
    CanonicalWorld one(s);
    StockWorld stock(s);
    GridOptions g;
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    const TerritoryMap map = make_partition("grid:2x1x1", s, 2, g);
    PartitionedWorld two(s, map);
    for (int i = 0; i < 120; ++i) one.step(), stock.step();
    two.step(120);
    const double y1 = upper_height(one.body_states()), y2 = upper_height(two.body_states()),
                 ys = upper_height(stock.body_states());
    std::printf("[ two boxes %s, %s ] upper box at y %.3f (one world), %.3f (K 2), %.3f (stock)\n", kPrecisionName,
                apart ? "filtered apart" : "default filter", y1, y2, ys);
    EXPECT_EQ(hash_hex(two.state_hash()), hash_hex(one.state_hash()));
    for (double y : {y1, y2, ys}) {
      if (apart) {
        EXPECT_NEAR(y, 0.5, 0.05);  // on the ground, inside the lower box
      } else {
        EXPECT_NEAR(y, 1.5, 0.05);  // on the lower box
      }
    }
  }
}

// Filters changed by input (UserInput::Kind::SetCollisionFilter), on the
// filtered pile: every second cube joins a group of its own at step 60 (its
// pairs end, those that still pass begin again), and takes its scene filter
// back at step 90 (pairs it passed through meanwhile push apart; later, two
// of them may overlap by more than the watchdog's 1 m); at step
// 170 the first cube is set to touch nothing and falls through the ground.
constexpr BodyId kFalls = 1;
constexpr int kFallsAt = 170;

std::vector<UserInput> filter_inputs() {
  std::vector<UserInput> out;
  auto filter = [&](std::int64_t step, const Body& b, std::uint32_t group, std::uint32_t mask) {
    UserInput in;
    in.kind = UserInput::Kind::SetCollisionFilter;
    in.step = step;
    in.id = b.id;
    in.collision_group = group;
    in.collision_mask = mask;
    in.sequence = out.size();
    out.push_back(in);
  };
  for (const Body& b : pile().bodies)
    if (!b.is_static && b.id % 2 == 0) filter(60, b, 16u, ~16u);
  for (const Body& b : pile().bodies)
    if (!b.is_static && b.id % 2 == 0) filter(90, b, b.collision_group, b.collision_mask);
  for (const Body& b : pile().bodies)
    if (b.id == kFalls) filter(kFallsAt, b, 0u, 0u);
  return out;
}

// One territory, lockstep, parking off, the inputs given before the run.
std::uint64_t input_reference() {
  static const std::uint64_t hash = [] {
    PartitionedOptions o;
    o.inputs = filter_inputs();
    PartitionedWorld one(pile(), make_partition("kmeans", pile(), 1, GridOptions{}), o);
    one.step(kSteps);
    return one.state_hash();
  }();
  return hash;
}

class FilterInputDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(FilterInputDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  const test::MatrixRun run =
      test::expect_one_world_hash(pile(), "filtered cube-pile 150, filters by input", c, kSteps, input_reference(),
                                  filter_inputs());
  if (c.territories > 1) EXPECT_GT(run.total.migrations_out, 0u);
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(run.total.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, FilterInputDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

// The inputs decide: without them the pile ends elsewhere, the cube set to
// touch nothing ends below the ground, and a Simulation given the same
// inputs (one territory, one thread) ends on the same hash.
TEST(FilterInputDecomposition, TheInputsChangeTheRunAsTheSimulationDoes) {
  PartitionedOptions o;
  o.inputs = filter_inputs();
  PartitionedWorld w(pile(), make_partition("kmeans", pile(), 2, GridOptions{}), o);
  w.step(kSteps);
  double y = 1e9;
  for (const BodyState& b : w.body_states())
    if (b.id == kFalls) y = double(b.origin[1]);
  Simulation sim(pile(), SimulationConfig{.threads = 1});
  for (const UserInput& in : filter_inputs()) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const std::uint64_t none = reference(false);
  std::printf("[ filtered cube-pile 150 %s, filters by input ] K 2 %s, one territory %s, Simulation %s, without "
              "the inputs %s; body %u at y %.2f\n",
              kPrecisionName, hash_hex(w.state_hash()).c_str(), hash_hex(input_reference()).c_str(),
              hash_hex(sim.state_hash()).c_str(), hash_hex(none).c_str(), kFalls, y);
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(input_reference()));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(input_reference()));
  EXPECT_NE(hash_hex(input_reference()), hash_hex(none));
  EXPECT_LT(y, -0.3);  // through the ground, which it touched before step 170
}

// Cells ceded every 10 steps (churn) while speculating, with the fuzzer's
// pauses, on each schedule (fuzz seeds from `seed` on), K 4: the inputs'
// filters reach every copy of their bodies wherever the bodies are owned
// then, and the run ends on `reference`.
void expect_churn_fuzzed_equal(const Scene& s, const char* label, const std::vector<UserInput>& inputs, int steps,
                               std::uint64_t reference, std::uint64_t seed) {
  for (Schedule schedule : {Schedule::Sequential, Schedule::Pool, Schedule::ThreadPerWorld}) {
    PartitionedOptions o;
    o.schedule = schedule;
    o.threads = schedule == Schedule::Pool ? 2 : 0;
    o.inputs = inputs;
    o.runtime.anticipation = 8;
    o.runtime.balance.policy = "churn";
    o.runtime.balance.period = 10;
    o.runtime.balance.seed = seed;
    detail::edit_testing_hooks(o).fuzz_seed = seed++;
    PartitionedWorld w(s, make_partition("kmeans", s, 4, GridOptions{}), o);
    w.step(steps);
    const BalanceTotals t = balance_totals(w.balance_log());
    std::printf("[ %s %s, K 4, churn, fuzz %llu, schedule %d ] %lld bodies moved; %s, one world %s\n", label,
                kPrecisionName, static_cast<unsigned long long>(seed - 1), static_cast<int>(schedule),
                static_cast<long long>(t.bodies_moved), hash_hex(w.state_hash()).c_str(),
                hash_hex(reference).c_str());
    EXPECT_GT(t.bodies_moved, 0);
    EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference)) << "schedule " << static_cast<int>(schedule);
  }
}

TEST(FilterInputDecomposition, ChurnFuzzedOnEverySchedule) {
  expect_churn_fuzzed_equal(pile(), "filtered cube-pile 150, filters by input", filter_inputs(), kSteps,
                            input_reference(), 3);
}

// A kinematic body's filter by input (kept as a command of its step in
// every world, Body::filter_commands): on the conveyor, pallet 2 touches
// nothing from step 30 to 40 (its boxes drop into it, then it catches them
// again), and the elevator (6) nothing from step 150 to 170, while it rests
// at the bottom with its boxes asleep on it (parked, with parking on: they
// come back at each of its filter changes, so that their contacts with it
// end as in a world that parks nothing); it rises from step 240 and wakes
// them. The same matrix: K 1 to 8, parking on and off, speculating, under
// SyncTest (which rebuilds every world at each step between the commands),
// and cells ceded under the fuzzer on every schedule.
constexpr int kConveyorSteps = 260;

const Scene& conveyor() {
  static const Scene s = test::scene("conveyor", 48);
  return s;
}

std::vector<UserInput> kinematic_filter_inputs() {
  std::vector<UserInput> out;
  auto filter = [&](std::int64_t step, BodyId id, std::uint32_t group, std::uint32_t mask) {
    UserInput in;
    in.kind = UserInput::Kind::SetCollisionFilter;
    in.step = step;
    in.id = id;
    in.collision_group = group;
    in.collision_mask = mask;
    in.sequence = out.size();
    out.push_back(in);
  };
  filter(30, 2, kDefaultCollisionGroup, 0u);
  filter(40, 2, kDefaultCollisionGroup, kAllCollisionGroups);
  filter(150, 6, kDefaultCollisionGroup, 0u);
  filter(170, 6, kDefaultCollisionGroup, kAllCollisionGroups);
  return out;
}

std::uint64_t kinematic_input_reference() {
  static const std::uint64_t hash = [] {
    PartitionedOptions o;
    o.inputs = kinematic_filter_inputs();
    o.runtime.parking = false;
    PartitionedWorld one(conveyor(), make_partition("kmeans", conveyor(), 1, GridOptions{}), o);
    one.step(kConveyorSteps);
    return one.state_hash();
  }();
  return hash;
}

class KinematicFilterInputDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(KinematicFilterInputDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  const test::MatrixRun run = test::expect_one_world_hash(conveyor(), "conveyor 48, kinematic filters by input", c,
                                                          kConveyorSteps, kinematic_input_reference(),
                                                          kinematic_filter_inputs());
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
  EXPECT_NE(hash_hex(kinematic_input_reference()), hash_hex(test::reference_hash(conveyor(), kConveyorSteps)))
      << "the inputs changed nothing";
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, KinematicFilterInputDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

TEST(KinematicFilterInputDecomposition, ChurnFuzzedOnEverySchedule) {
  expect_churn_fuzzed_equal(conveyor(), "conveyor 48, kinematic filters by input", kinematic_filter_inputs(),
                            kConveyorSteps, kinematic_input_reference(), 11);
}

}  // namespace
}  // namespace soda
