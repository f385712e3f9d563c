// Inputs known before the run (PartitionedOptions::inputs, docs/inputs.md)
// under load balancing: the `rain` load scene, whose later waves are
// add_body inputs (scene_inputs), ends on the hash of the Simulation's
// replay of the same inputs (the embedding API) and of one territory, under
// `churn` and `diffusive`, for K = 2, 4, 8, anticipation 0 and 8, with
// SyncTest and validation on. The validator follows the inputs: it accepts
// the bodies they add and still catches a body that is lost.
#include <algorithm>
#include <cctype>
#include <map>
#include <mutex>
#include <vector>

#include "runtime/partitioned_test_util.h"
#include "runtime/setter_plan.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/registry.h"
#include "step/validator.h"

namespace soda {
namespace {

constexpr int kRainN = 64;
constexpr int kRainSteps = 120;  // waves at steps 30, 60, 90 are inputs

SceneParams rain_params() { return SceneParams{kRainN, 1, false}; }

// The embedding API's replay: each input as its call, in list order.
std::uint64_t simulation_hash(const Scene& s, const std::vector<UserInput>& inputs, int steps, int territories) {
  Simulation sim(s, SimulationConfig{.territories = territories});
  for (const UserInput& in : inputs) sim.give(in);
  EXPECT_TRUE(sim.advance_to(sim.time_of(steps)));
  const std::uint64_t h = sim.state_hash();
  sim.stop();
  return h;
}

// Rain's reference hashes, computed once per test binary: the Simulation's
// replay on one territory, and one PartitionedWorld territory given the
// inputs (no balancing).
struct RainReference {
  std::uint64_t api = 0;
  std::uint64_t one_territory = 0;
};
const RainReference& rain_reference() {
  static std::once_flag once;
  static RainReference ref;
  std::call_once(once, [] {
    const Scene s = make_scene("rain", rain_params());
    const std::vector<UserInput> inputs = scene_inputs("rain", rain_params());
    ref.api = simulation_hash(s, inputs, kRainSteps, 1);
    PartitionedOptions o;
    o.runtime.validate = true;
    o.inputs = inputs;
    PartitionedWorld one(s, make_partition("kmeans", s, 1, GridOptions{}), o);
    one.step(kRainSteps);
    ref.one_territory = one.state_hash();
  });
  return ref;
}

struct Case {
  const char* policy;
  int territories;
  int anticipation;
};

class RainBalance : public ::testing::TestWithParam<Case> {};

TEST_P(RainBalance, HashEqualsTheApiReplayAndOneTerritory) {
  const Case c = GetParam();
  const Scene s = make_scene("rain", rain_params());
  const std::vector<UserInput> inputs = scene_inputs("rain", rain_params());
  ASSERT_FALSE(inputs.empty());
  const TerritoryMap map =
      make_partition("grid:" + std::to_string(c.territories) + "x1x1", s, c.territories, GridOptions{});
  PartitionedOptions o;
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.validate = true;
  o.runtime.anticipation = c.anticipation;
  o.sync_test = 1;
  o.runtime.balance.policy = c.policy;
  o.runtime.balance.period = 10;
  o.runtime.balance.seed = 7;
  o.inputs = inputs;
  PartitionedWorld world(s, map, o);
  world.step(kRainSteps);
  const RainReference& ref = rain_reference();
  EXPECT_EQ(hash_hex(ref.one_territory), hash_hex(ref.api));
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(ref.api));
  EXPECT_GT(world.body_count(), s.bodies.size()) << "the inputs' waves must have arrived";
  EXPECT_EQ(world.sync_rollbacks(), static_cast<std::uint64_t>(kRainSteps));
  const BalanceTotals t = balance_totals(world.balance_log());
  EXPECT_EQ(t.balance_steps, (kRainSteps - 1) / 10);
  if (std::string(c.policy) == "churn") {
    EXPECT_GT(t.cells_moved, 0);
    EXPECT_GT(t.bodies_moved, 0);
  }
  std::printf("[ rain %d %s K=%d anticipation %d ] %lld cells, %lld bodies moved; %zu bodies at the end; %s\n",
              kRainN, c.policy, c.territories, c.anticipation, static_cast<long long>(t.cells_moved),
              static_cast<long long>(t.bodies_moved), world.body_count(), hash_hex(world.state_hash()).c_str());
}

std::vector<Case> rain_cases() {
#ifdef __SANITIZE_THREAD__
  // ThreadSanitizer looks for races, not for hashes: each policy once, on 8
  // and 4 threads with speculation (the Release build runs all 12; the 12
  // cost about 4 minutes of CI under TSan).
  return {Case{"churn", 8, 8}, Case{"diffusive", 4, 8}};
#endif
  std::vector<Case> out;
  for (const char* policy : {"churn", "diffusive"})
    for (int anticipation : {0, 8})
      for (int k : {2, 4, 8}) out.push_back(Case{policy, k, anticipation});
  return out;
}

INSTANTIATE_TEST_SUITE_P(Runtime, RainBalance, ::testing::ValuesIn(rain_cases()),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           return std::string(info.param.policy) + "_K" + std::to_string(info.param.territories) +
                                  "_a" + std::to_string(info.param.anticipation);
                         });

// Every kind of input, removals included, with validation and speculation:
// the API's hash for every K.
TEST(PartitionedInputs, EveryKindGivesTheApiHash) {
  const Scene s = test::scene("falling-cubes", 60);
  const BodyId added = 100000;
  std::vector<UserInput> inputs(5);
  inputs[0].kind = UserInput::Kind::AddBody;
  inputs[0].step = 10;
  inputs[0].body = s.bodies.back();
  inputs[0].body.id = added;
  inputs[0].body.position = Vec3(0, 14, 0);
  inputs[1].kind = UserInput::Kind::SetVelocity;
  inputs[1].step = 20;
  inputs[1].id = s.bodies.back().id;
  inputs[1].linear = Vec3(3, 4, 0);
  inputs[1].angular = Vec3(0, 1, 0);
  inputs[2].kind = UserInput::Kind::ApplyImpulse;
  inputs[2].step = 20;  // the same step: list order
  inputs[2].id = added;
  inputs[2].linear = Vec3(-2, 0, 1);
  inputs[3].kind = UserInput::Kind::RemoveBody;
  inputs[3].step = 40;
  inputs[3].id = s.bodies.back().id;
  inputs[4].kind = UserInput::Kind::RemoveBody;
  inputs[4].step = 0;  // before the first step; listed last, applied first
  inputs[4].id = s.bodies[s.bodies.size() - 2].id;
  ASSERT_FALSE(s.bodies.back().is_static);
  const int steps = 60;
  const std::string api = hash_hex(simulation_hash(s, [&] {
    std::vector<UserInput> by_step = inputs;
    std::stable_sort(by_step.begin(), by_step.end(), [](const UserInput& a, const UserInput& b) { return a.step < b.step; });
    return by_step;
  }(), steps, 1));
  for (int k : {1, 2, 4})
    for (int anticipation : {0, 8}) {
      PartitionedOptions o;
      o.schedule = Schedule::ThreadPerWorld;
      o.runtime.validate = true;
      o.runtime.anticipation = anticipation;
      o.inputs = inputs;
      PartitionedWorld world(s, make_partition("kmeans", s, k, GridOptions{}), o);
      world.step(steps);
      EXPECT_EQ(hash_hex(world.state_hash()), api) << "K=" << k << " anticipation " << anticipation;
      EXPECT_EQ(world.body_count(), s.bodies.size() - 1);  // one added, two removed
    }
}

// The setters (gravity, mass, friction, restitution, user data;
// runtime/setter_plan.h) under SyncTest (every step restored and re-run)
// and churn (cells ceded every 10 steps: bodies migrate with their new
// properties), lockstep and speculating: the API's one-territory hash.
TEST(PartitionedInputs, SettersUnderSyncTestAndChurnGiveTheApiHash) {
  const Scene s = test::scene("cube-pile", 120);  // a pile across the borders: ghosts live through the changes
  const std::vector<UserInput> inputs = test::setter_plan(s);
  const int steps = 100;
  const std::string api = hash_hex(simulation_hash(s, inputs, steps, 1));
  const std::string none = hash_hex(simulation_hash(s, {}, steps, 1));
  EXPECT_NE(api, none);
  for (int k : {2, 4})
    for (int anticipation : test::sync_test_anticipations()) {
      if (test::kThreadSanitizer && k == 2) continue;  // K 4 under TSan
      PartitionedOptions o;
      o.schedule = Schedule::ThreadPerWorld;
      o.runtime.validate = true;
      o.runtime.anticipation = anticipation;
      o.sync_test = 1;
      o.runtime.balance.policy = "churn";
      o.runtime.balance.period = 10;
      o.runtime.balance.seed = 7;
      o.inputs = inputs;
      PartitionedWorld world(s, make_partition("kmeans", s, k, GridOptions{}), o);
      world.step(steps);
      const BalanceTotals t = balance_totals(world.balance_log());
      std::printf("[ setters, cube-pile 120, churn K=%d anticipation %d ] %lld bodies moved, %llu sync rollbacks; "
                  "%s (API one territory %s)\n",
                  k, anticipation, static_cast<long long>(t.bodies_moved),
                  static_cast<unsigned long long>(world.sync_rollbacks()), hash_hex(world.state_hash()).c_str(),
                  api.c_str());
      EXPECT_GT(t.bodies_moved, 0);
      EXPECT_EQ(world.sync_rollbacks(), static_cast<std::uint64_t>(steps));
      EXPECT_EQ(hash_hex(world.state_hash()), api) << "K=" << k << " anticipation " << anticipation;
    }
}

TEST(PartitionedInputs, BadInputsAreRefusedNamingTheInput) {
  const Scene s = test::scene("falling-cubes", 20);
  const TerritoryMap map = make_partition("kmeans", s, 2, GridOptions{});
  const auto refused = [&](UserInput in, const std::string& needle) {
    PartitionedOptions o;
    o.inputs = {in};
    try {
      PartitionedWorld world(s, map, o);
      ADD_FAILURE() << "accepted: " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("PartitionedOptions::inputs: input 0"), std::string::npos) << e.what();
    }
  };
  UserInput unknown;
  unknown.step = 5;
  unknown.id = 99999;
  refused(unknown, "no body has that id");
  UserInput in_use;
  in_use.kind = UserInput::Kind::AddBody;
  in_use.step = 5;
  in_use.body = s.bodies.back();
  refused(in_use, "is in use");
  // From a snapshot at step 10: an input at step 5 is in the past.
  PartitionedWorld first(s, map);
  first.step(10);
  UserInput late;
  late.step = 5;
  late.id = s.bodies.back().id;
  PartitionedOptions o;
  o.inputs = {late};
  EXPECT_THROW(PartitionedWorld(first.snapshot(), map, o), std::invalid_argument);
}

// The validator's expected bodies follow the inputs (a Validator of one
// world, substeps 1; reports of internal steps done).
WorldStepReport report_of(std::int64_t step, std::vector<BodyId> owned) {
  WorldStepReport r;
  r.step = step;
  r.bullet_objects = owned.size();
  r.owned = std::move(owned);
  return r;
}

TEST(ValidatorInputs, AcceptsAddedBodiesAndCatchesALostOne) {
  Scene s;
  Body a;
  a.id = 1;
  s.bodies.push_back(a);
  Validator v(s, 1);
  UserInput add;
  add.kind = UserInput::Kind::AddBody;
  add.step = 2;
  add.body.id = 7;
  v.expect(add, 1);
  UserInput remove;
  remove.kind = UserInput::Kind::RemoveBody;
  remove.step = 4;
  remove.id = 1;
  v.expect(remove, 1);
  EXPECT_NO_THROW(v.report(report_of(1, {1})));
  EXPECT_NO_THROW(v.report(report_of(2, {1})));     // body 7 arrives in step 3
  EXPECT_NO_THROW(v.report(report_of(3, {1, 7})));
  EXPECT_NO_THROW(v.report(report_of(4, {1, 7})));  // body 1 leaves before step 5
  EXPECT_NO_THROW(v.report(report_of(5, {7})));
  try {
    v.report(report_of(6, {}));
    ADD_FAILURE() << "a lost added body passed";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("body 7 has no owner"), std::string::npos) << e.what();
  }
  try {
    v.report(report_of(7, {1, 7}));
    ADD_FAILURE() << "a removed body still owned passed";
  } catch (const ValidationError& e) {
    EXPECT_NE(std::string(e.what()).find("body 1 is owned but is not in the scene then"), std::string::npos)
        << e.what();
  }
  Validator early(s, 1);
  early.expect(add, 1);
  EXPECT_THROW(early.report(report_of(2, {1, 7})), ValidationError);  // before its step
  EXPECT_THROW(early.report(report_of(3, {1, 99})), ValidationError);  // nobody's body
}

}  // namespace
}  // namespace soda
