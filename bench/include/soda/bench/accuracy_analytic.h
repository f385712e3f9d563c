// bench/ — the analytic scenes against their closed forms, each with a fixed
// tolerance whose reason is documented next to it (docs/accuracy.md,
// "Analytic scenes"). Used by tests/accuracy and `soda bench analytic`.
#pragma once

#include <string>
#include <vector>

#include "soda/runtime/run.h"

namespace soda {

struct AnalyticCheck {
  std::string scene;      // free-fall | incline | resting-stack | rolling-sphere
  std::string quantity;   // what is compared
  double measured = 0;    // the error measured (units in `unit`)
  double tolerance = 0;   // pass when measured <= tolerance
  std::string unit;
  bool pass = false;
  std::string reason;     // why this tolerance
};

/// Runs the four analytic scenes (registry defaults, steps as stated in
/// docs/accuracy.md) on `world` in this build's precision and returns every
/// check. Deterministic; takes well under a second.
std::vector<AnalyticCheck> run_analytic_checks(WorldKind world = WorldKind::Canonical);

/// Machine epsilon of btScalar (float: 2^-23, double: 2^-52).
double scalar_epsilon();

}  // namespace soda
