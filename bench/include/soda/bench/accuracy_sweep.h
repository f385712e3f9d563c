// bench/ — `soda bench accuracy`: run time against error, one factor at a
// time around a default (step size, solver iterations, precision, CCD,
// territories), every row's error measured against a high-fidelity reference
// (small step, many iterations, double precision) and its run time as a ratio
// to the default configuration measured in the same sweep. docs/accuracy.md.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "soda/bench/accuracy.h"

namespace soda {

struct SweepOptions {
  std::vector<std::string> scenes{"falling-cubes", "cube-pile"};
  std::vector<int> sizes{1000, 500};  // n per scene; one value: every scene
  std::uint64_t seed = 1;
  double duration = 10.0;             // simulated seconds (steps = duration / dt)
  double horizon = 1.0;               // s, short-horizon trajectory error window
  double sample_period = 1.0 / 30.0;  // s, a whole number of steps of every dt
  // The default configuration; the axes vary one factor from it.
  double default_dt = 1.0 / 60.0;
  int default_iterations = 10;
  std::vector<double> dts{1.0 / 30, 1.0 / 60, 1.0 / 120, 1.0 / 240, 1.0 / 480};
  std::vector<int> iterations{4, 10, 20, 50, 100};
  std::vector<std::string> precisions{"float", "double"};
  bool ccd_axis = true;                  // canonical (off), stock off, stock on
  std::vector<int> territories{1, 2, 4, 8};
  std::vector<std::pair<double, int>> combos{{1.0 / 120, 20}, {1.0 / 240, 20}};  // (dt, iterations) pairs
  // The reference.
  double reference_dt = 1.0 / 960.0;
  int reference_iterations = 100;
  std::string reference_precision = "double";
  bool floor_row = true;  // the reference's settings in the other precision: the chaos floor
  // Processes and files.
  std::string sibling;        // binary of the other precision; empty or missing: those rows are "not available"
  std::string work_dir;       // trace files of the other precision go here (must exist)
  std::string reference_dir;  // if set: reference traces are cached here and reused when present
  MetricOptions metrics;
};

struct SweepRow {
  std::string scene;
  int n = 0;
  std::uint64_t seed = 0;
  std::string axis;   // default | dt | iterations | precision | ccd | territories | combo | reference | floor
  std::string value;  // the factor's value, as text
  std::string world;
  std::string precision;
  double dt = 0;
  int iterations = 0;
  bool ccd = false;
  int territories = 1;
  int steps = 0;
  double wall_seconds = 0;
  double cost_vs_default = 0;
  std::string state_hash;
  std::size_t sleeping = 0;
  bool has_errors = false;  // metrics below are measured
  ErrorMetrics errors;
  std::string decomposition_error;  // territories axis only: "0" or empty
  double horizon = 0;
  double ref_dt = 0;
  int ref_iterations = 0;
  std::string ref_precision;
  std::string status = "ok";  // ok | not available | failed | hash differs (kSweepHashDiffers)
  std::string note;
};

/// Runs the sweep; calls on_row for every row as soon as it is known.
/// Configurations that cannot run (the other precision's binary is missing,
/// territories > 1 refused by run_scene) become rows with status
/// "not available" and the error message as note: never a made-up number.
std::vector<SweepRow> run_accuracy_sweep(const SweepOptions& options,
                                         const std::function<void(const SweepRow&)>& on_row = {});

/// The status of a territories row whose state hash differs from the
/// one-territory run's (K > 1), or from the traced default run's (K = 1).
inline constexpr const char* kSweepHashDiffers = "hash differs";

/// `soda bench accuracy`'s exit status: 1 if any row's hash differs
/// (kSweepHashDiffers: the exactness contract is broken), else 0. Rows that
/// are "not available" or "failed" to run are reported, not judged.
int sweep_exit_status(const std::vector<SweepRow>& rows);

std::string sweep_csv_header();
std::string sweep_csv_row(const SweepRow& row);

/// Steps a run of `duration` seconds at `dt` takes (rounded to the nearest whole step).
int steps_for(double duration, double dt);

/// Records a trace of a registry scene (or .json scene file) with dt,
/// iterations and steps overridden: what `soda bench accuracy-trace` runs.
struct TraceRequest {
  std::string scene;
  int n = 0;
  std::uint64_t seed = 1;
  bool random_scale = false;
  double dt = 1.0 / 60.0;
  int iterations = 10;
  int steps = 600;
  WorldKind world = WorldKind::Canonical;
  bool ccd = false;
  double sample_period = 1.0 / 30.0;
  double horizon = 1.0;
};
Scene request_scene(const TraceRequest& request);
Trace record_request(const TraceRequest& request);
/// The same request run by `binary` (the other precision) in a child
/// process, through a trace file at `trace_path`.
Trace record_request_in(const std::string& binary, const TraceRequest& request, const std::string& trace_path);

}  // namespace soda
