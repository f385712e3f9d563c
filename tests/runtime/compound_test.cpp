// Compound shapes (docs/scene-format.md, "Compound shapes") keep
// decomposition invariance: the compounds scene (chairs and tables made of
// boxes falling onto static tables, across territory borders) ends with the
// one-world hash for K = 1, 2, 4, 8 territories, speculating (anticipation
// 8), under SyncTest and with parking on and off. A compound pair holds one
// manifold in SODA's worlds (worlds/src/compound_contact.h), which ghosts
// seed, migrations carry and rollbacks restore like any other.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "runtime/partitioned_test_util.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"

namespace soda {
namespace {

constexpr int kSteps = 200;

const Scene& furniture() {
  static const Scene s = test::scene("compounds", 60);
  return s;
}

std::uint64_t reference(bool parking) { return test::reference_hash(furniture(), kSteps, parking); }

class CompoundDecomposition : public ::testing::TestWithParam<test::MatrixCase> {};

TEST_P(CompoundDecomposition, EqualsTheOneWorldHash) {
  const test::MatrixCase c = GetParam();
  static const std::uint64_t ref = reference(false);
  const test::MatrixRun run = test::expect_one_world_hash(furniture(), "compounds 60", c, kSteps, ref);
  const WorldMetrics& t = run.total;
  if (c.territories > 1) {
    EXPECT_GT(t.ghosts_sent, 0u);
    EXPECT_GT(t.manifolds_seeded, 0u);
    EXPECT_GT(t.migrations_out, 0u);
    EXPECT_GT(t.merged_islands, 0u);
  }
  if (c.anticipation > 0 && c.territories > 1) EXPECT_GT(t.bets, 0u);
  if (c.sync_test > 0) EXPECT_GT(run.sync_rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Partitioned, CompoundDecomposition,
    test::decomposition_matrix(),
    [](const auto& info) { return test::matrix_case_name(info.param); });

// Parking does not change the one world's result; the pieces land and
// settle on the ground and the static tables (none falls through), in SODA's
// worlds and in stock Bullet (its own compound algorithms).
TEST(CompoundDecomposition, PiecesLandInEveryWorldKind) {
  EXPECT_EQ(hash_hex(reference(true)), hash_hex(reference(false)));
  CanonicalWorld one(furniture());
  StockWorld stock(furniture());
  for (int i = 0; i < 400; ++i) one.step(), stock.step();
  for (const auto& [name, states] : {std::pair{"canonical", one.body_states()}, {"stock", stock.body_states()}}) {
    double lowest = 1e9, highest = -1e9;
    for (const BodyState& b : states) {
      if (b.id <= 2) continue;  // the ground and the static tables
      lowest = std::min(lowest, double(b.origin[1]));
      highest = std::max(highest, double(b.origin[1]));
    }
    std::printf("[ compounds 60 %s, %s, 400 steps ] piece origins between y %.3f and %.3f\n", kPrecisionName, name,
                lowest, highest);
    EXPECT_GT(lowest, 0.0) << name;   // no piece's origin inside the ground (an upside-down chair's seat: 0.03)
    EXPECT_LT(highest, 4.0) << name;  // everything has come down
  }
}

}  // namespace
}  // namespace soda
