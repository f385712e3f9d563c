// The analytic scenes against their closed forms, within the tolerances
// documented in docs/accuracy.md, in this build's precision.
#include <gtest/gtest.h>

#include "soda/bench/accuracy_analytic.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

void expect_all_pass(WorldKind world) {
  const auto checks = run_analytic_checks(world);
  ASSERT_EQ(checks.size(), 11u);
  for (const AnalyticCheck& c : checks)
    EXPECT_TRUE(c.pass) << kPrecisionName << " " << world_kind_name(world) << " " << c.scene << ": " << c.quantity
                        << " = " << c.measured << " " << c.unit << ", tolerance " << c.tolerance << " (" << c.reason
                        << ")";
}

TEST(Analytic, CanonicalWorldWithinTolerances) { expect_all_pass(WorldKind::Canonical); }

TEST(Analytic, StockWorldWithinTolerances) { expect_all_pass(WorldKind::Stock); }

TEST(Analytic, FreeFallIsBullet_sSemiImplicitEulerToTheBit) {
  // Same operations in the same precision: the measured difference is zero,
  // not merely within the rounding tolerance.
  for (const AnalyticCheck& c : run_analytic_checks(WorldKind::Canonical))
    if (c.scene == "free-fall" && c.quantity.find("semi-implicit") != std::string::npos) {
      EXPECT_EQ(c.measured, 0.0) << c.quantity;
    }
}

TEST(Analytic, TolerancesAreFixedAndExplained) {
  for (const AnalyticCheck& c : run_analytic_checks(WorldKind::Canonical)) {
    EXPECT_FALSE(c.reason.empty()) << c.quantity;
    EXPECT_GE(c.tolerance, 0.0) << c.quantity;
  }
}

}  // namespace
}  // namespace soda
