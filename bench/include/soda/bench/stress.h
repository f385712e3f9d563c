// bench/ — `soda stress`: the numerical-stability suite (BENCHMARKS.md
// "Stress scenes", DESIGN.md §5). Each case has a documented pass criterion
// (docs/stress.md); a failure is a finding and is reported, never hidden.
//
// Every case checks every body's state for NaN/Inf after every step; the
// response to a non-finite state is to stop the case and fail it, naming the
// step.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "soda/runtime/run.h"

namespace soda {

struct StressCase {
  std::string name;       // e.g. "tower-20", "bullet-200-stock-ccd"
  std::string group;      // tower | pyramid | mass-ratio | ... | heavy-slide | far-origin | dense-pile | long-run
  std::string scene;      // registry scene
  int n = 0;              // the scene's --n
  int steps = 600;
  WorldKind world = WorldKind::Canonical;
  bool ccd = false;       // stock world only
  bool both_precisions = false;  // far-origin: run in the float and the double build
  std::string criterion;  // the pass criterion, in words
  double dt = 0;          // > 0: override the scene's step (steps are then scaled to keep the simulated time)
  int iterations = 0;     // > 0: override the scene's solver iterations
  int substeps = 0;       // > 0: override the scene's substeps
  std::string variant{};  // diagnosis: solver_variant.h (canonical world only)
  int solver_threads = 1; // > 1: the canonical world's coloured solve on a pool (results never depend on it)
  double bound = 0;       // > 0: replaces the case's main pass bound (the joint cases; tests show a case can fail)
};

/// The case with dt and iterations overridden (0: unchanged); steps are
/// scaled so that the simulated time stays what the criterion names.
StressCase with_settings(StressCase c, double dt, int iterations);

struct StressResult {
  StressCase c;
  std::string precision;
  std::string status;   // pass | FAIL | error
  std::string measured; // the numbers the verdict rests on
  double metric = 0;    // the main measured quantity
  double threshold = 0; // its pass threshold
  int steps_run = 0;
  double wall_seconds = 0;
  std::size_t sleeping = 0;
  std::string state_hash;
};

/// The suite, in report order. quick: the same cases, shorter where the
/// criterion holds over a shorter run (stands 2 s instead of 60 s, ...);
/// far-origin keeps its 20 s (settling is its criterion). Every SODA case
/// passes at the defaults in both versions.
std::vector<StressCase> stress_suite(bool quick = false);

/// Runs one case in this build's precision.
StressResult run_stress_case(const StressCase& c);

std::string stress_csv_header();
std::string stress_csv_row(const StressResult& r);
/// JSON round trip of a result (how `soda stress` collects the cases it runs
/// in the other precision's binary).
nlohmann::json stress_json(const StressResult& r);
StressResult stress_from_json(const nlohmann::json& j);

/// A markdown table of the results (docs/results/stress.md).
std::string stress_markdown(const std::vector<StressResult>& results);

/// Verdict counts, SODA's rows (the canonical world, the partitioned
/// runtime) apart from the comparison rows run in Bullet's stock world
/// (`-stock`, `-stock-ccd`, every row of `--stock`), which are stock
/// Bullet's verdicts and no SODA case.
struct StressTally {
  int pass = 0, fail = 0, other = 0;                  // SODA's rows
  int stock_pass = 0, stock_fail = 0, stock_other = 0;  // stock Bullet's rows
};
StressTally stress_tally(const std::vector<StressResult>& results);
/// `soda stress`'s exit status: 0 when every SODA row passed, 1 when one
/// FAILed or any row could not run (an error, or the other precision's
/// binary missing). A stock Bullet comparison row's pass or FAIL never
/// changes it: it shows what stock Bullet does.
int stress_exit_status(const StressTally& t);
/// "SODA: 27 pass, 1 FAIL, 0 other; stock Bullet (comparison rows, not SODA
/// cases): 3 pass, 3 FAIL, 0 other".
std::string stress_tally_text(const StressTally& t);

}  // namespace soda
