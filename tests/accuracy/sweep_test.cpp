// A tiny accuracy sweep (n <= 150, a few steps) produces well-formed CSV rows.
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "soda/bench/accuracy_sweep.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

// Splits one CSV line (fields may be quoted, with "" for a quote).
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

SweepOptions tiny() {
  SweepOptions o;
  o.scenes = {"falling-cubes", "cube-pile"};
  o.sizes = {60, 40};
  o.duration = 0.5;
  o.horizon = 0.25;
  o.dts = {1.0 / 30, 1.0 / 60, 1.0 / 120};
  o.iterations = {4, 10};
  o.precisions = {"float", "double"};
  o.territories = {1, 2};
  o.combos = {{1.0 / 120, 20}};
  o.reference_dt = 1.0 / 240;
  o.reference_iterations = 20;
  o.reference_precision = kPrecisionName;  // in process: no sibling binary in a unit test
  o.sibling = "";                           // the other precision: "not available"
  return o;
}

TEST(Sweep, TinySweepWritesWellFormedRows) {
  const SweepOptions o = tiny();
  std::vector<std::string> streamed;
  const auto rows = run_accuracy_sweep(o, [&](const SweepRow& r) { streamed.push_back(sweep_csv_row(r)); });
  const std::vector<std::string> header = split_csv(sweep_csv_header());
  ASSERT_EQ(streamed.size(), rows.size());
  // Per scene: reference, floor, default, 3 dt, 2 iterations, 2 precisions,
  // 3 CCD, 1 combo, 2 territories.
  EXPECT_EQ(rows.size(), 2u * 16u);
  const std::set<std::string> statuses = {"ok", "not available", "failed", kSweepHashDiffers};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SweepRow& r = rows[i];
    const std::vector<std::string> f = split_csv(streamed[i]);
    ASSERT_EQ(f.size(), header.size()) << streamed[i];
    EXPECT_EQ(f[0], r.scene);
    EXPECT_TRUE(statuses.count(r.status)) << r.status;
    if (r.status == "ok") {
      EXPECT_TRUE(r.has_errors) << r.axis << " " << r.value;
      EXPECT_GT(r.wall_seconds, 0.0) << r.axis << " " << r.value;
      EXPECT_GE(r.errors.traj_rms, 0.0);
      EXPECT_GE(r.errors.pen_max, r.errors.pen_mean);
      EXPECT_EQ(r.state_hash.size(), 16u);
    } else {
      // Never a made-up number: rows that did not run carry no metrics.
      EXPECT_FALSE(r.note.empty());
      if (r.status == "not available") {
        EXPECT_FALSE(r.has_errors);
        EXPECT_TRUE(r.decomposition_error.empty());
      }
    }
  }
}

TEST(Sweep, AxesBehaveAsDocumented) {
  const auto rows = run_accuracy_sweep(tiny());
  for (const SweepRow& r : rows) {
    if (r.axis == "reference") {
      EXPECT_EQ(r.status, "ok");
      EXPECT_EQ(r.errors.traj_rms, 0.0);
      EXPECT_EQ(r.errors.com_err, 0.0);
    }
    if (r.axis == "precision" && r.precision == kPrecisionName) { EXPECT_EQ(r.status, "ok"); }
    if (r.axis == "precision" && r.precision != kPrecisionName) {
      EXPECT_EQ(r.status, "not available");  // no sibling binary given
      EXPECT_NE(r.note.find("separate binary"), std::string::npos) << r.note;
    }
    if (r.axis == "floor") {
      // The reference's settings in the other precision: no sibling binary here.
      EXPECT_EQ(r.status, "not available");
      EXPECT_NE(r.precision, kPrecisionName);
    }
    if (r.axis == "ccd" && r.value == "on (stock)") {
      EXPECT_EQ(r.status, "ok");
      EXPECT_TRUE(r.ccd);
      EXPECT_EQ(r.world, "stock");
    }
    if (r.axis == "territories" && r.territories == 1) {
      // run_scene's result and the traced default run are the same run.
      EXPECT_EQ(r.status, "ok") << r.note;
      EXPECT_EQ(r.decomposition_error, "0");
    }
    if (r.axis == "territories" && r.territories > 1) {
      // The exactness contract: K territories give the one-territory hash.
      EXPECT_EQ(r.status, "ok") << r.scene << " K=" << r.territories << ": " << r.note;
      EXPECT_EQ(r.decomposition_error, "0") << r.scene << " K=" << r.territories << ": " << r.note;
    }
    if (r.axis == "dt" && r.value == "1/60") { EXPECT_NEAR(r.cost_vs_default, 1.0, 1e-12); }  // the same run
  }
}

// A territories row whose hash differs fails the sweep (exit status 1);
// rows that could not run are reported, not judged.
TEST(Sweep, AHashMismatchFailsTheSweep) {
  std::vector<SweepRow> rows(3);
  rows[0].axis = "default";
  rows[1].axis = "precision";
  rows[1].status = "not available";
  rows[2].axis = "territories";
  rows[2].territories = 4;
  EXPECT_EQ(sweep_exit_status(rows), 0);
  rows[2].status = kSweepHashDiffers;
  EXPECT_EQ(sweep_exit_status(rows), 1);
}

TEST(Sweep, RefusesMismatchedSizes) {
  SweepOptions o = tiny();
  o.sizes = {10, 20, 30};
  EXPECT_THROW(run_accuracy_sweep(o), std::invalid_argument);
}

}  // namespace
}  // namespace soda
