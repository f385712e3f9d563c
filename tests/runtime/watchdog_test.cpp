// The watchdog: a real blow-up (a step too long for a heavy box on a light
// one) is caught, stopped on or healed, and so is a blow-up injected into
// one body (its velocity becomes NaN at the end of a step): it is caught by the world that owns it before anything of
// that step leaves the world. Stop: the run ends with a WatchdogError naming
// the step, the world and the body. Heal: the worlds roll back to a step they
// all keep, re-simulate the bad step with substeps and go on — and the result
// is the same for every partition, and equals one CanonicalWorld that takes
// the same substeps at that step.
#include "runtime/partitioned_test_util.h"
#include "driver/testing_hooks.h"  // runtime/src: the test-only knobs

#include "soda/worlds/watchdog.h"
#include "soda/worlds/world_snapshot.h"

#include <vector>

namespace soda {
namespace {

constexpr int kBodies = 250;
constexpr int kSteps = 200;
constexpr std::int64_t kBadStep = 120;

// A body that is in contact at kBadStep (the pile has settled by then).
BodyId victim(const Scene& s) {
  CanonicalWorld w(s);
  for (int i = 0; i < kBadStep; ++i) w.step();
  const std::vector<ManifoldState> contacts = w.contact_state();
  for (const ManifoldState& m : contacts)
    for (const Body& b : s.bodies)
      if (b.id == m.id1 && !b.is_static) return m.id1;
  return s.bodies.back().id;
}

PartitionedOptions options(WatchdogResponse response, BodyId body, Schedule schedule = Schedule::Sequential) {
  PartitionedOptions o;
  o.schedule = schedule;
  o.threads = schedule == Schedule::Pool ? 2 : 0;
  o.runtime.validate = true;
  o.runtime.watchdog.response = response;
  detail::edit_testing_hooks(o).inject_fault = {kBadStep, body};
  return o;
}

// The one-world run of what the heal should do: kBadStep - 1 steps, the bad
// step as heal_substeps substeps, the rest as usual.
std::uint64_t healed_reference(const Scene& s, int substeps) {
  CanonicalWorld w(s);
  for (std::int64_t i = 0; i < kBadStep - 1; ++i) w.step();
  WorldSnapshot at = w.snapshot();
  at.settings.substeps *= substeps;
  auto fine = std::make_unique<CanonicalWorld>(at);
  fine->step();
  WorldSnapshot after = fine->snapshot();
  after.settings.substeps = s.settings.substeps;
  CanonicalWorld rest(after);
  for (std::int64_t i = kBadStep; i < kSteps; ++i) rest.step();
  return rest.state_hash();
}

TEST(Watchdog, StopNamesStepWorldAndBody) {
  const Scene s = test::scene("cube-pile", kBodies);
  const BodyId body = victim(s);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedWorld world(s, map, options(WatchdogResponse::Stop, body));
  try {
    world.step(kSteps);
    FAIL() << "the injected blow-up went unnoticed";
  } catch (const WatchdogError& e) {
    std::printf("stop: %s\n", e.what());
    EXPECT_EQ(e.step(), kBadStep);
    ASSERT_FALSE(e.findings().empty());
    EXPECT_EQ(e.findings().front().body, body);
    EXPECT_EQ(e.findings().front().kind, WatchdogFinding::Kind::NonFinite);
    const std::string what = e.what();
    EXPECT_NE(what.find("step " + std::to_string(kBadStep)), std::string::npos);
    EXPECT_NE(what.find("body " + std::to_string(body)), std::string::npos);
    EXPECT_NE(what.find("world " + std::to_string(e.world())), std::string::npos);
  }
}

TEST(Watchdog, OffLetsTheBlowUpThroughUntilSomethingElseBreaks) {
  // Without the watchdog the NaN body reaches the next step's halo check
  // (a PartitionError) — the watchdog is what turns it into a clear verdict
  // at the step it happened.
  const Scene s = test::scene("cube-pile", kBodies);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  PartitionedWorld world(s, map, options(WatchdogResponse::Off, victim(s)));
  EXPECT_THROW(world.step(kSteps), std::exception);
}

struct HealCase {
  const char* partition;
  int territories;
  Schedule schedule;
};

class WatchdogHeal : public ::testing::TestWithParam<HealCase> {};

TEST_P(WatchdogHeal, RollsBackResimulatesAndMatchesOneWorld) {
  const HealCase c = GetParam();
  const Scene s = test::scene("cube-pile", kBodies);
  const BodyId body = victim(s);
  const TerritoryMap map = make_partition(c.partition, s, c.territories, GridOptions{});
  PartitionedWorld world(s, map, options(WatchdogResponse::Heal, body, c.schedule));
  world.step(kSteps);
  EXPECT_EQ(world.steps_done(), kSteps);
  ASSERT_EQ(world.heals(), 1);
  EXPECT_EQ(world.healed_steps().front(), kBadStep);
  const std::uint64_t expected = healed_reference(s, PartitionedOptions{}.runtime.watchdog.heal_substeps);
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(expected));
  // Not the run without a heal: the bad step really was re-simulated.
  EXPECT_NE(world.state_hash(), test::reference_hash(s, kSteps));
  std::printf("[ heal %s K=%d %s ] body %u at step %lld: %s\n", c.partition, c.territories,
              schedule_name(c.schedule), body, static_cast<long long>(kBadStep), hash_hex(expected).c_str());
}

INSTANTIATE_TEST_SUITE_P(Runtime, WatchdogHeal,
                         ::testing::Values(HealCase{"kmeans", 1, Schedule::Sequential},
                                           HealCase{"kmeans", 4, Schedule::Sequential},
                                           HealCase{"rcb", 8, Schedule::ThreadPerWorld},
                                           HealCase{"kmeans", 3, Schedule::Pool}),
                         [](const ::testing::TestParamInfo<HealCase>& info) {
                           return std::string(info.param.partition) + "_" +
                                  std::to_string(info.param.territories) + "_" +
                                  (info.param.schedule == Schedule::Sequential
                                       ? "sequential"
                                       : info.param.schedule == Schedule::Pool ? "pool" : "threads");
                         });

// A real blow-up, no hook: a 1000 kg box resting on a 1 kg box, stepped at
// a third of a second with 5 iterations (the island gets sqrt(1000) x 5 =
// 159; at the scene's 10 a substepped solve holds it). In step
// kRealBlowUp - 1 the heavy box sinks more than 1 m into the light one; the
// contact points of step kRealBlowUp find it (a step's contacts come from
// the positions the step before left), so stop names step kRealBlowUp, and
// heal re-simulates the step before — the step that made the penetration —
// in 8 substeps, and every later step of the run passes the watchdog's
// check (the stack still falls: at 0.33 s no step keeps a 1000:1 stack up;
// it sinks again in step 13, found at 14, a second heal, which kRealSteps
// stops short of: repeated heals are
// HealsEveryBlowUpOfAStepTooLongForEveryPartition's).
// One heal, the same for 1 and 2 territories, and the hash of one
// CanonicalWorld that takes that step in substeps.
Scene heavy_on_light() {
  Scene s = test::scene("mass-ratio", 1000);
  s.settings.dt = 0.33;
  s.settings.iterations = 5;
  return s;
}

constexpr int kRealBlowUp = 5;
constexpr int kRealSteps = 12;

TEST(Watchdog, StopFindsTheRealBlowUpAtTheStepAfterIt) {
  const Scene s = heavy_on_light();
  PartitionedOptions o;
  o.runtime.watchdog.response = WatchdogResponse::Stop;
  PartitionedWorld world(s, make_partition("kmeans", s, 1, GridOptions{}), o);
  try {
    world.step(kRealSteps);
    FAIL() << "the blow-up went unnoticed";
  } catch (const WatchdogError& e) {
    std::printf("stop: %s\n", e.what());
    EXPECT_EQ(e.step(), kRealBlowUp);
    ASSERT_FALSE(e.findings().empty());
    EXPECT_EQ(e.findings().front().kind, WatchdogFinding::Kind::Penetration);
    EXPECT_GT(e.findings().front().value, 1.0);
  }
}

TEST(Watchdog, HealsARealBlowUpAndStaysWithinBounds) {
  const Scene s = heavy_on_light();
  // The reference: one CanonicalWorld, step kRealBlowUp - 1 in 8 substeps.
  CanonicalWorld w(s);
  for (int i = 0; i < kRealBlowUp - 2; ++i) w.step();
  WorldSnapshot at = w.snapshot();
  at.settings.substeps *= PartitionedOptions{}.runtime.watchdog.heal_substeps;
  auto fine = std::make_unique<CanonicalWorld>(at);
  fine->step();
  WorldSnapshot after = fine->snapshot();
  after.settings.substeps = s.settings.substeps;
  CanonicalWorld rest(after);
  for (int i = kRealBlowUp - 1; i < kRealSteps; ++i) {
    rest.step();
    EXPECT_TRUE(rest.watchdog_findings(WatchdogLimits{}).empty()) << "step " << i + 1;
  }
  for (int territories : {1, 2}) {
    PartitionedOptions o;
    o.runtime.watchdog.response = WatchdogResponse::Heal;
    o.runtime.validate = true;
    PartitionedWorld world(s, make_partition("grid:" + std::to_string(territories) + "x1x1", s, territories,
                                             GridOptions{}),
                           o);
    world.step(kRealSteps);  // every step checked; a finding the heal left would throw
    EXPECT_EQ(world.steps_done(), kRealSteps);
    ASSERT_EQ(world.heals(), 1) << territories << " territories";
    EXPECT_EQ(world.healed_steps().front(), kRealBlowUp - 1);
    EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(rest.state_hash())) << territories << " territories";
    std::printf("[ heal K=%d ] healed step %lld: %s\n", territories,
                static_cast<long long>(world.healed_steps().front()), hash_hex(world.state_hash()).c_str());
  }
}

// A real blow-up healed again and again, the same for 1 and 4 territories:
// `scene` run `steps` steps with Heal on each, at least `min_heals` heals,
// the same healed steps and the same hash.
void expect_same_heals_for_every_partition(const Scene& scene, int steps, int min_heals) {
  std::vector<std::int64_t> healed;
  std::uint64_t hash = 0;
  for (int territories : {1, 4}) {
    PartitionedOptions o;
    o.runtime.watchdog.response = WatchdogResponse::Heal;
    o.schedule = territories > 1 ? Schedule::ThreadPerWorld : Schedule::Sequential;
    PartitionedWorld world(scene, make_partition("kmeans", scene, territories, GridOptions{}), o);
    world.step(steps);
    std::printf("[ heal %s K=%d ] %d heals, %s\n", scene.name.c_str(), territories, world.heals(),
                hash_hex(world.state_hash()).c_str());
    EXPECT_GE(world.heals(), min_heals) << scene.name;
    if (territories == 1) {
      healed = world.healed_steps();
      hash = world.state_hash();
    } else {
      EXPECT_EQ(world.healed_steps(), healed) << scene.name;
      EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(hash)) << scene.name;
    }
  }
}

// Blow-ups again and again: falling cubes stepped at
// 0.15 s land 1 m deep in the ground, one after another. Every landing is
// healed, the same steps for 1 and 4 territories, and the same hash.
TEST(Watchdog, HealsEveryBlowUpOfAStepTooLongForEveryPartition) {
  Scene s = test::scene("falling-cubes", 300);
  s.settings.dt = 0.15;
  expect_same_heals_for_every_partition(s, 120, 2);
}

// Joint scenes healed. The heals rebuild the worlds from kept states that
// carry the joints (and whether each has broken), and re-simulate the step
// with every joint. chain-bridge stepped at 0.65 s, where boxes sink more
// than 1 m into the planks again and again: the same heals and hash for 1
// and 4 territories. A ragdoll's pelvis made NaN at kBadStep: one heal, and
// the hash of one CanonicalWorld that takes that step in substeps.
TEST(Watchdog, HealsJointScenesForEveryPartition) {
  Scene bridge = test::scene("chain-bridge", 12);
  bridge.settings.dt = 0.65;
  expect_same_heals_for_every_partition(bridge, 60, 1);
  const Scene ragdolls = test::scene("ragdolls", 8);
  ASSERT_FALSE(ragdolls.joints.empty());
  const std::uint64_t expected = healed_reference(ragdolls, PartitionedOptions{}.runtime.watchdog.heal_substeps);
  for (int territories : {1, 4}) {
    const BodyId pelvis = 1;
    PartitionedWorld world(ragdolls, make_partition("kmeans", ragdolls, territories, GridOptions{}),
                           options(WatchdogResponse::Heal, pelvis, territories > 1 ? Schedule::ThreadPerWorld
                                                                                  : Schedule::Sequential));
    world.step(kSteps);
    std::printf("[ heal ragdolls K=%d ] %d heals, %s (one world %s)\n", territories, world.heals(),
                hash_hex(world.state_hash()).c_str(), hash_hex(expected).c_str());
    ASSERT_EQ(world.heals(), 1);
    EXPECT_EQ(world.healed_steps().front(), kBadStep);
    EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(expected));
    EXPECT_NE(world.state_hash(), test::reference_hash(ragdolls, kSteps));
  }
}

TEST(Watchdog, HealGivesUpWithAClearErrorWhenTheStepStaysBad) {
  // Limits no state can meet: every re-simulation fails again.
  const Scene s = test::scene("cube-pile", kBodies);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  PartitionedOptions o = options(WatchdogResponse::Heal, victim(s));
  detail::edit_testing_hooks(o).inject_fault = {};
  o.runtime.watchdog.limits.max_penetration = -1.0;  // any contact point at all is "too deep"
  o.runtime.watchdog.max_heals = 2;
  PartitionedWorld world(s, map, o);
  try {
    world.step(kSteps);
    FAIL() << "expected the heal to give up";
  } catch (const WatchdogError& e) {
    EXPECT_NE(std::string(e.what()).find("gave up after 2 heals"), std::string::npos) << e.what();
  }
}

TEST(Watchdog, CanonicalWorldFindsWhatTheTerritoriesFind) {
  const Scene s = test::scene("cube-pile", kBodies);
  CanonicalWorld w(s);
  for (int i = 0; i < 50; ++i) w.step();
  EXPECT_TRUE(w.watchdog_findings(WatchdogLimits{}).empty());
  WatchdogLimits strict;
  strict.max_speed = 0.0;  // everything that moves is "too fast"
  EXPECT_FALSE(w.watchdog_findings(strict).empty());
}

TEST(Watchdog, ParsesResponses) {
  EXPECT_EQ(parse_watchdog_response("heal"), WatchdogResponse::Heal);
  EXPECT_EQ(parse_watchdog_response("stop"), WatchdogResponse::Stop);
  EXPECT_EQ(parse_watchdog_response("off"), WatchdogResponse::Off);
  EXPECT_THROW(parse_watchdog_response("fix"), std::invalid_argument);
}

}  // namespace
}  // namespace soda
