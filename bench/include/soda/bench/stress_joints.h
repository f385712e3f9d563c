// bench/ — the joint cases of `soda stress` (stress.h; pass criteria:
// docs/stress.md, "Joint cases"): a long chain swinging from its anchor, a
// ragdoll pile, a heavy box on a light chain, motorised hinges.
#pragma once

#include <string>
#include <vector>

#include "soda/bench/stress.h"
#include "soda/scene/scene.h"

namespace soda {

/// The joint cases, in report order, each followed by its stock Bullet
/// comparison row (`-stock`). quick: shorter runs and a smaller pile.
void add_joint_stress_cases(std::vector<StressCase>& suite, bool quick);

/// Whether a group is one of the joint cases' (run_joint_stress_case runs it).
bool is_joint_stress_group(const std::string& group);

/// Runs a joint case on `scene` (the case's, settings applied) in the
/// canonical or the stock world and gives `r` its verdict and figures.
void run_joint_stress_case(StressResult& r, const Scene& scene, const StressCase& c);

}  // namespace soda
