// Subcommands defined outside main.cpp. Each add_* registers a subcommand
// and returns it with the function that runs it once parsed.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "soda/loadbalance/policy.h"
#include "soda/replay/view_frame.h"
#include "soda/runtime/run.h"
#include "soda/scene/scene.h"

namespace soda::cli {

/// The one meaning of every speed ratio the benchmarks print, the footer
/// of `soda --help`, `soda bench --help` and every benchmark's help
/// (docs/cli.md, "What the ratios mean").
inline constexpr const char* kRatioMeaning =
    "Speed ratios (ratio_vs_*, speedup_*, the vs_* columns, every speed-up printed): baseline time / our time, "
    "> 1 is faster, both measured in the same process. Figures named cost_*: our time / the baseline's, > 1 costs "
    "more (docs/cli.md, \"What the ratios mean\").";

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

/// The median of `values` (not empty): the middle one, or the mean of the
/// middle two. cmd_queries.cpp.
double median(std::vector<double> values);

/// Under `bench`: `speculation` (anticipation against lockstep on a scene
/// whose load alternates between territories). cmd_speculation.cpp;
/// docs/speculation-bench.md.
Command add_speculation_command(CLI::App& bench);

/// Under `bench`: `sleepers` (the sleepers scene against its active bodies
/// alone). cmd_sleepers.cpp; docs/skip.md.
Command add_sleepers_command(CLI::App& bench);

/// `soda bench idle-territories` (cmd_idle.cpp).
Command add_idle_command(CLI::App& bench);

/// `soda bench queries`: ray casts against a running Simulation, and the
/// slowdown they cause (cmd_queries.cpp; docs/embedding.md, "Queries").
Command add_queries_command(CLI::App& bench);

/// `soda bench defaults`: the solver defaults against Bullet's own solver
/// settings, interleaved (cmd_defaults.cpp; docs/stress.md).
Command add_defaults_command(CLI::App& bench);

/// `soda bench broadphase`: the worlds' DBVT against an incremental sweep
/// and prune on a scene's recorded boxes (cmd_broadphase.cpp;
/// docs/results/broadphase.md).
Command add_broadphase_command(CLI::App& bench);

/// `stress`: the numerical-stability suite. cmd_stress.cpp; docs/stress.md.
Command add_stress_command(CLI::App& app);

/// The knobs of BalanceOptions but the policy (--lb-period, --lb-seed,
/// --lb-smoothing, --lb-overload, --lb-underload, --lb-max-cells), shared by
/// `run` and `lb`. main.cpp.
void add_balance_options(CLI::App& cmd, BalanceOptions& balance);

/// `lb`: a load-balance experiment, one scene under each balance policy.
/// cmd_lb.cpp; docs/loadbalance.md.
Command add_lb_command(CLI::App& app);

/// `replay-info FILE`: a replay file's header, frames and size.
/// cmd_replay_info.cpp; docs/replay-format.md.
Command add_replay_info_command(CLI::App& app);
/// What `soda run --serve PORT` was asked. docs/viewer.md.
struct ServeOptions {
  int port = 0;                 // on 127.0.0.1; 0: any free port (printed)
  double linger_seconds = 60;   // serving on after the run; < 0: until Ctrl-C
  bool wait_for_viewer = false; // start stepping once a viewer has opened the page
};

/// The port `soda view` serves on by default.
inline constexpr int kDefaultViewPort = 8765;

/// `soda run --serve`: runs `scene` through a Simulation (the run's
/// territories, partition, threads, speculation) while serving it to the
/// browser viewer live, prints the state hash (the same as without
/// --serve), serves the last frame for serve.linger_seconds, then stops.
/// Ctrl-C stops the run (or the linger) cleanly: exit code 130. Throws
/// std::invalid_argument for run options a Simulation does not support.
/// cmd_view.cpp.
int serve_run(const Scene& scene, const RunConfig& config, const ServeOptions& serve);

/// `view FILE [--port P] [--seconds S]`: serves a replay file (ReplayReader)
/// to the browser viewer until Ctrl-C (exit 0) or S seconds. cmd_view.cpp.
Command add_view_command(CLI::App& app);

/// Serves `source` on 127.0.0.1:serve.port, prints the URL, and returns
/// after serve.linger_seconds (< 0: at Ctrl-C), 0. cmd_view.cpp.
int serve_source(std::shared_ptr<replay::FrameSource> source, const ServeOptions& serve);

}  // namespace soda::cli
