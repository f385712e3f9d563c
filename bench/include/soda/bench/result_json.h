// The JSON rows `soda run --json` and `soda bench --json` write (docs/cli.md).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "soda/bench/bench.h"
#include "soda/scene/registry.h"

namespace soda {

/// Identification of a run: scene, parameters, seed, precision, settings.
struct RunDescription {
  std::string scene;      // registry name or file path
  SceneParams params;     // n, seed, random_scale (generated scenes)
  const Scene* resolved;  // the scene actually run (dt, iterations, bodies)
  RunConfig config;
};

/// Per-stage costs of one world (WorldMetrics::stages): an object keyed by
/// stage name (stage.h), each {cpu_seconds, wait_seconds, items, messages,
/// bytes}.
nlohmann::json stages_json(const WorldMetrics& m);
/// Messages one world sent (WorldMetrics::traffic, message_traffic.h):
/// {internal_steps, flows: [{to, kind, messages, bytes, steps,
/// max_per_step}], rounds: {kind: n}, island_depth_sum, island_depth_max};
/// kinds in lower case ("ghosts", "glue", ...).
nlohmann::json traffic_json(const WorldMetrics& m);
/// Speculation figures of one world, or of a run (total_metrics over its
/// worlds: the "speculation" object of a row).
nlohmann::json speculation_json(const WorldMetrics& m);
/// One row for `soda run`.
nlohmann::json run_json(const RunDescription& d, const RunResult& r);
/// One row for `soda bench`: run_json of the best run plus baseline fields.
nlohmann::json bench_json(const RunDescription& d, const BenchResult& b);

/// Writes `j` (pretty, trailing newline) to `path`, or to stdout for "-".
/// Throws std::runtime_error naming the path if it cannot.
void write_json(const nlohmann::json& j, const std::string& path);

}  // namespace soda
