// Decomposition invariance: a scene simulated by K territory worlds that only
// exchange messages (serialised to bytes and back) ends bit-identical to the
// one-world CanonicalWorld, for K = 2, 3, 4, 8, 16 and kmeans, rcb and grid:
// partitions. Every case also checks that the mechanisms it relies on fired
// (ghosts, seeded manifolds, migrations, merged islands) and runs with the
// validation mode on (one owner per body, one holder per contact state).
#include "runtime/partitioned_test_util.h"
#include "driver/testing_hooks.h"  // runtime/src: the test-only knobs

namespace soda {
namespace {

constexpr int kBodies = 250;
constexpr int kSteps = 300;

struct Case {
  const char* scene;
  const char* partition;
  int territories;
};

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string s = std::string(info.param.scene) + "_" + info.param.partition + "_" + std::to_string(info.param.territories);
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

class Decomposition : public ::testing::TestWithParam<Case> {};

TEST_P(Decomposition, MatchesOneWorld) {
  const Case c = GetParam();
  const Scene s = test::scene(c.scene, kBodies);
  const TerritoryMap map = make_partition(c.partition, s, c.territories, GridOptions{});
  ASSERT_EQ(map.world_count(), c.territories);
  PartitionedWorld world(s, map, PartitionedOptions{.runtime = {.validate = true}});
  world.step(kSteps);
  const std::uint64_t reference = test::reference_hash(s, kSteps);
  const WorldMetrics t = test::total(world.metrics());
  std::printf("[ %s %s %s K=%d ] %d steps: one world %s, partitioned %s; %s\n", c.scene, kPrecisionName, c.partition,
              c.territories, kSteps, hash_hex(reference).c_str(), hash_hex(world.state_hash()).c_str(),
              test::summary(t).c_str());
  EXPECT_EQ(hash_hex(world.state_hash()), hash_hex(reference));
  if (world.state_hash() != reference) ADD_FAILURE() << test::first_divergence(s, map, kSteps);
  EXPECT_GT(t.ghosts_sent, 0u);
  EXPECT_EQ(t.ghosts_sent, t.ghosts_received);
  EXPECT_GT(t.manifolds_seeded, 0u);
  EXPECT_GT(t.migrations_out, 0u);
  EXPECT_EQ(t.migrations_out, t.migrations_in);
  EXPECT_GT(t.merged_islands, 0u);
  EXPECT_GT(t.islands_solved, 0u);
  EXPECT_LE(t.islands_solved, t.merged_islands);
  EXPECT_GT(world.bytes_sent(), 0u);
}

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const char* scene : {"falling-cubes", "cube-pile"}) {
    for (int k : {2, 3, 4, 8, 16})
      for (const char* partition : {"kmeans", "rcb"}) out.push_back({scene, partition, k});
    out.push_back({scene, "grid:2x1x1", 2});
    out.push_back({scene, "grid:3x1x1", 3});
    out.push_back({scene, "grid:2x1x2", 4});
    out.push_back({scene, "grid:2x1x4", 8});
    out.push_back({scene, "grid:4x1x4", 16});
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Scenes, Decomposition, ::testing::ValuesIn(cases()), case_name);

// The per-step comparison used to locate a divergence finds none.
TEST(Decomposition, EveryStepMatchesOneWorld) {
  const Scene s = test::scene("cube-pile", 120);
  const TerritoryMap map = make_partition("rcb", s, 4, GridOptions{});
  const std::string diff = test::first_divergence(s, map, 150);
  std::printf("[ cube-pile %s rcb K=4 ] 150 steps compared body by body every step: %s\n", kPrecisionName,
              diff.empty() ? "identical" : diff.c_str());
  EXPECT_EQ(diff, "");
}

// In-memory values and bytes give the same result.
TEST(Decomposition, TransportDoesNotMatter) {
  const Scene s = test::scene("cube-pile", 150);
  const TerritoryMap map = make_partition("kmeans", s, 4, GridOptions{});
  PartitionedWorld bytes(s, map, PartitionedOptions{.serialise = true});
  PartitionedWorld values(s, map, PartitionedOptions{.serialise = false});
  bytes.step(200);
  values.step(200);
  std::printf("[ cube-pile %s kmeans K=4 ] serialised %s (%llu messages, %llu bytes), values %s\n", kPrecisionName,
              hash_hex(bytes.state_hash()).c_str(), static_cast<unsigned long long>(bytes.messages_sent()),
              static_cast<unsigned long long>(bytes.bytes_sent()), hash_hex(values.state_hash()).c_str());
  EXPECT_EQ(bytes.state_hash(), values.state_hash());
  EXPECT_EQ(values.bytes_sent(), 0u);
}

// Solving each border island once at its root (default) or in every world
// it spans gives the same result; the root solves it once.
TEST(Decomposition, SolvingEverywhereMatchesSolvingAtTheRoot) {
  const Scene s = test::scene("cube-pile", 150);
  const TerritoryMap map = make_partition("rcb", s, 8, GridOptions{});
  PartitionedOptions solve_everywhere;
  detail::edit_testing_hooks(solve_everywhere).solve_everywhere = true;
  PartitionedWorld root(s, map), everywhere(s, map, solve_everywhere);
  root.step(200);
  everywhere.step(200);
  const WorldMetrics a = test::total(root.metrics()), b = test::total(everywhere.metrics());
  std::printf("[ cube-pile %s rcb K=8 ] solved at the root %s (%llu solves, %.3f s CPU), everywhere %s (%llu solves, "
              "%.3f s CPU)\n",
              kPrecisionName, hash_hex(root.state_hash()).c_str(), static_cast<unsigned long long>(a.islands_solved),
              a.cpu_seconds, hash_hex(everywhere.state_hash()).c_str(),
              static_cast<unsigned long long>(b.islands_solved), b.cpu_seconds);
  EXPECT_EQ(root.state_hash(), everywhere.state_hash());
  EXPECT_EQ(hash_hex(root.state_hash()), hash_hex(test::reference_hash(s, 200)));
  EXPECT_EQ(b.islands_solved, b.merged_islands);
  EXPECT_LT(a.islands_solved, b.islands_solved);
}

// Stepping in several calls is stepping once.
TEST(Decomposition, SplitStepsMatch) {
  const Scene s = test::scene("falling-cubes", 150);
  const TerritoryMap map = make_partition("rcb", s, 3, GridOptions{});
  PartitionedWorld once(s, map), pieces(s, map);
  once.step(200);
  pieces.step(50), pieces.step(1), pieces.step(0), pieces.step(149);
  EXPECT_EQ(once.steps_done(), pieces.steps_done());
  EXPECT_EQ(hash_hex(once.state_hash()), hash_hex(pieces.state_hash()));
  EXPECT_EQ(hash_hex(once.state_hash()), hash_hex(test::reference_hash(s, 200)));
}

}  // namespace
}  // namespace soda
