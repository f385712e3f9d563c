// Subcommands defined outside main.cpp. Each add_* registers a subcommand
// and returns it with the function that runs it once parsed.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "soda/loadbalance/policy.h"

namespace soda::cli {

struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

/// Under `bench`: `accuracy` (the run time vs error sweep), `accuracy-trace`
/// (one traced run, what the sweep spawns in the other precision's binary),
/// `analytic` (the analytic scenes against their closed forms).
/// cmd_accuracy.cpp; docs/accuracy.md.
std::vector<Command> add_accuracy_commands(CLI::App& bench);

/// A step size from "1/60" or a number of seconds (> 0). Throws
/// std::invalid_argument naming the text. cmd_accuracy.cpp.
double parse_step_size(const std::string& text);

/// Under `bench`: `speculation` (anticipation against lockstep on a scene
/// whose load alternates between territories). cmd_speculation.cpp;
/// docs/speculation-bench.md.
Command add_speculation_command(CLI::App& bench);

/// Under `bench`: `sleepers` (the sleepers scene against its active bodies
/// alone, #18). cmd_sleepers.cpp; docs/skip.md.
Command add_sleepers_command(CLI::App& bench);

/// `stress`: the numerical-stability suite. cmd_stress.cpp; docs/stress.md.
Command add_stress_command(CLI::App& app);

/// The knobs of BalanceOptions but the policy (--lb-period, --lb-seed,
/// --lb-smoothing, --lb-overload, --lb-underload, --lb-max-cells), shared by
/// `run` and `lb`. main.cpp.
void add_balance_options(CLI::App& cmd, BalanceOptions& balance);

/// `lb`: a load-balance experiment, one scene under each balance policy.
/// cmd_lb.cpp; docs/loadbalance.md.
Command add_lb_command(CLI::App& app);

}  // namespace soda::cli
