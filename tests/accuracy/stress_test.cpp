// The stress suite: every SODA case passes at the defaults (short versions
// here; the ctest `stress_subset` runs `soda stress` on the cheap cases at
// full length and needs exit status 0), stock Bullet's comparison rows
// report their verdict without counting, and the exit status follows the
// SODA rows only.
#include <cstdio>
#include <set>

#include <gtest/gtest.h>

#include "soda/bench/stress.h"

namespace soda {
namespace {

TEST(Stress, SuiteListsEveryDocumentedCase) {
  const auto suite = stress_suite();
  std::set<std::string> names;
  for (const StressCase& c : suite) {
    names.insert(c.name);
    EXPECT_FALSE(c.criterion.empty()) << c.name;
  }
  for (const char* n : {"tower-10", "tower-20", "tower-30", "pyramid-20", "pyramid-30", "mass-ratio-1:10",
                        "mass-ratio-1:100", "mass-ratio-1:1000", "bullet-50-canonical", "bullet-200-stock",
                        "bullet-500-stock-ccd", "far-origin-1e3", "far-origin-1e4", "far-origin-1e5",
                        "dense-pile-1000", "long-run", "tower-50", "card-house-5", "heavy-drop-10",
                        "sphere-chain-100", "mixed-sizes-5", "bullet-border-200"})
    EXPECT_TRUE(names.count(n)) << n;
  for (const StressCase& c : suite)
    if (c.name == "long-run") { EXPECT_EQ(c.steps, 100000); }
}

TEST(Stress, StockBulletRowsAreCountedApartFromSodas) {
  std::vector<StressResult> rows;
  for (const StressCase& c : stress_suite(true))
    if (c.name == "tower-10" || c.name == "dense-pile-200" || c.name == "bullet-50-stock" ||
        c.name == "bullet-50-stock-ccd") {
      StressResult r;
      r.c = c;
      r.status = c.name == "tower-10" || c.name == "bullet-50-stock-ccd" ? "pass" : "FAIL";
      rows.push_back(r);
    }
  ASSERT_EQ(rows.size(), 4u);
  const StressTally t = stress_tally(rows);
  EXPECT_EQ(t.pass, 1);
  EXPECT_EQ(t.fail, 1);
  EXPECT_EQ(t.stock_pass, 1);
  EXPECT_EQ(t.stock_fail, 1);
  EXPECT_EQ(t.other + t.stock_other, 0);
  EXPECT_NE(stress_markdown(rows).find("stock (comparison)"), std::string::npos);
}

TEST(Stress, ExitStatusFollowsTheSodaRowsOnly) {
  StressTally t;
  t.pass = 22;
  t.stock_pass = 3;
  t.stock_fail = 3;  // stock Bullet without CCD passes through the wall: its verdict, not SODA's
  EXPECT_EQ(stress_exit_status(t), 0);
  t.fail = 1;
  EXPECT_EQ(stress_exit_status(t), 1);
  t.fail = 0;
  t.other = 1;  // a case that could not run
  EXPECT_EQ(stress_exit_status(t), 1);
  t.other = 0;
  t.stock_other = 1;
  EXPECT_EQ(stress_exit_status(t), 1);
}

// Every SODA case of the short suite passes at the defaults (stock Bullet's
// rows: any verdict, but a verdict). The slowest cases (pyramid-30 about
// 9 s, dense-pile, long-run) are left to `soda stress`.
TEST(Stress, QuickSodaCasesPassAtTheDefaults) {
  for (const StressCase& c : stress_suite(true)) {
    if (c.name == "pyramid-30" || c.group == "long-run" || c.group == "dense-pile") continue;
    const StressResult r = run_stress_case(c);
    std::printf("%-6s %-22s %s\n", r.status.c_str(), c.name.c_str(), r.measured.c_str());
    if (c.world == WorldKind::Stock) {
      EXPECT_TRUE(r.status == "pass" || r.status == "FAIL") << c.name << ": " << r.status << " " << r.measured;
    } else {
      EXPECT_EQ(r.status, "pass") << c.name << ": " << r.measured << " (criterion: " << c.criterion << ")";
    }
    EXPECT_EQ(r.steps_run, c.steps) << c.name;
    EXPECT_FALSE(r.measured.empty());
    const StressResult back = stress_from_json(stress_json(r));
    EXPECT_EQ(stress_csv_row(back), stress_csv_row(r));
  }
}

// --quick keeps far-origin's whole 20 s: settling is its criterion.
TEST(Stress, QuickFarOriginHasTimeToSettle) {
  for (const StressCase& c : stress_suite(true))
    if (c.group == "far-origin") { EXPECT_EQ(c.steps, 1200) << c.name; }
}

TEST(Stress, CcdStopsTheBulletThatTunnelsWithoutIt) {
  // The classic finding, pinned: at 200 m/s the sphere passes a 0.1 m wall
  // without CCD, and stock Bullet's CCD stops it.
  StressCase c{"b", "bullet-vs-wall", "bullet-vs-wall", 200, 60, WorldKind::Stock, false, false, ""};
  EXPECT_EQ(run_stress_case(c).status, "FAIL");
  c.ccd = true;
  EXPECT_EQ(run_stress_case(c).status, "pass");
}

}  // namespace
}  // namespace soda
