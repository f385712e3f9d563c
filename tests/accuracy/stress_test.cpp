// The stress suite runs and reports a verdict for every case (short
// versions: pass or FAIL are both findings; an error is not).
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

TEST(Stress, QuickCasesGiveAVerdict) {
  for (const StressCase& c : stress_suite(true)) {
    if (c.group == "long-run" || c.group == "dense-pile") continue;  // the slowest; covered by `soda stress`
    const StressResult r = run_stress_case(c);
    EXPECT_TRUE(r.status == "pass" || r.status == "FAIL") << c.name << ": " << r.status << " " << r.measured;
    EXPECT_EQ(r.steps_run, c.steps) << c.name;
    EXPECT_FALSE(r.measured.empty());
    const StressResult back = stress_from_json(stress_json(r));
    EXPECT_EQ(stress_csv_row(back), stress_csv_row(r));
  }
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
