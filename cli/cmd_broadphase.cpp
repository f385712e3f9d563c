// `soda bench broadphase` (docs/results/broadphase.md): the DBVT the worlds
// use against an incremental sweep and prune, a one-axis sort and sweep
// (sort_sweep_broadphase.h) and Bullet's DBVT defaults,
// on one scene's boxes recorded from a stock world with sleeping on, awake
// bodies only (parking). One untimed replay per broadphase checks that all
// report the same exact pairs at every step (broadphase_replay.h); then the
// timed replays, interleaved (the order rotates every repeat). Per
// broadphase: the seconds of every repeat, the least and the median, per
// step, and dbvt / it (> 1: it is faster than the DBVT in use). JSON on
// stdout (and --out FILE), a summary on stderr; exit 1 if the exact pairs
// differ.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <string>

#include "broadphase_replay.h"
#include "commands.h"
#include "soda/bench/result_json.h"
#include "soda/scene/registry.h"
#include "soda/scene/validate.h"

namespace soda::cli {
namespace {

constexpr const char* kTimingContains =
    "wall seconds of the broadphase's own work summed over the steps: per step, the leaving bodies' pairs "
    "removed in one sweep and their proxies destroyed, the arriving bodies' proxies created, setAabb for every "
    "other awake body, calculateOverlappingPairs (and, for dbvt, the worlds' removal of every stale pair); not "
    "the recording, the statics' proxies, nor the pair checks";

// Up to this many bodies, the DBVT's exact pairs are also checked against
// every two bodies tested (brute_force_hashes: a few million box tests a step).
constexpr std::size_t kBruteForceBodies = 2000;

struct BroadphaseOptions {
  std::string scene = "falling-cubes";
  SceneParams params;
  int steps = 600;
  int repeat = 3;
  std::string out;
};

struct Measured {
  BroadphaseKind kind;
  ReplayResult checked;                // the untimed-check replay: pair counts
  std::vector<double> seconds;         // per repeat: the whole replay
  std::vector<double> first_step;      // per repeat: step 0 (every body awake then created)
  double least() const { return *std::min_element(seconds.begin(), seconds.end()); }
  double least_after_first_step() const {
    double least = seconds.front() - first_step.front();
    for (std::size_t r = 1; r < seconds.size(); ++r) least = std::min(least, seconds[r] - first_step[r]);
    return least;
  }
  double median() const { return cli::median(seconds); }
};

double mean_of(const std::vector<std::size_t>& v) {
  return v.empty() ? 0.0 : static_cast<double>(std::accumulate(v.begin(), v.end(), std::size_t{0})) / v.size();
}

std::size_t total_of(const std::vector<std::vector<std::uint32_t>>& per_step) {
  std::size_t n = 0;
  for (const auto& v : per_step) n += v.size();
  return n;
}

// The first step at which `m`'s exact pairs differ from `base`'s, or -1.
int first_difference(const Measured& base, const Measured& m) {
  for (std::size_t s = 0; s < base.checked.exact_hash.size(); ++s)
    if (base.checked.exact_hash[s] != m.checked.exact_hash[s] ||
        base.checked.exact_pairs[s] != m.checked.exact_pairs[s])
      return static_cast<int>(s);
  return -1;
}

nlohmann::json measured_json(const Measured& m, const Measured& base, int steps, double stepping_seconds) {
  const int diff = first_difference(base, m);
  return {{"broadphase", m.kind.name},
          {"what", m.kind.what},
          {"seconds", m.seconds},
          {"seconds_least", m.least()},
          {"seconds_median", m.median()},
          {"seconds_per_step_least", m.least() / steps},
          {"seconds_per_step_median", m.median() / steps},
          {"first_step_seconds_least", *std::min_element(m.first_step.begin(), m.first_step.end())},
          {"seconds_after_first_step_least", m.least_after_first_step()},
          {"ratio_vs_dbvt", base.least() / std::max(m.least(), 1e-12)},
          {"ratio_vs_dbvt_median", base.median() / std::max(m.median(), 1e-12)},
          {"share_of_stock_stepping", m.least() / std::max(stepping_seconds, 1e-12)},
          {"raw_pairs_end", m.checked.raw_pairs.back()},
          {"raw_pairs_mean", mean_of(m.checked.raw_pairs)},
          {"exact_pairs_end", m.checked.exact_pairs.back()},
          {"exact_pairs_mean", mean_of(m.checked.exact_pairs)},
          {"exact_pairs_equal_to_dbvt", diff < 0},
          {"first_differing_step", diff < 0 ? nlohmann::json() : nlohmann::json(diff)}};
}

nlohmann::json recording_json(const Recording& rec) {
  std::vector<std::size_t> awake;
  for (const auto& a : rec.awake) awake.push_back(a.size());
  return {{"stepping_seconds", rec.stepping_seconds},
          {"what", "a stock Bullet world (btDiscreteDynamicsWorld, sleeping on) stepped once; its wall seconds "
                   "stepping, for scale"},
          {"awake_mean", mean_of(awake)},
          {"awake_max", *std::max_element(awake.begin(), awake.end())},
          {"awake_end", awake.back()},
          {"statics", rec.statics.size()},
          {"arrivals", total_of(rec.arriving)},
          {"departures", total_of(rec.leaving)}};
}

int run_broadphase(BroadphaseOptions& o) {
  Scene scene = make_scene(o.scene, o.params);
  scene.settings.steps = o.steps;
  validate_scene(scene, o.scene);
  std::fprintf(stderr, "  recording %s n=%d, %d steps in a stock world...\n", o.scene.c_str(), o.params.n, o.steps);
  const Recording rec = record_scene(scene, o.steps);
  std::vector<Measured> runs;
  for (const BroadphaseKind& kind : broadphase_kinds()) runs.push_back({kind, replay(rec, kind, true), {}, {}});
  for (int r = 0; r < o.repeat; ++r) {
    for (std::size_t i = 0; i < runs.size(); ++i) {
      Measured& m = runs[(i + static_cast<std::size_t>(r)) % runs.size()];
      const ReplayResult res = replay(rec, m.kind, false);
      m.seconds.push_back(std::accumulate(res.step_seconds.begin(), res.step_seconds.end(), 0.0));
      m.first_step.push_back(res.step_seconds.front());
      std::fprintf(stderr, "  repeat %d/%d %-10s %.4f s\n", r + 1, o.repeat, m.kind.name.c_str(), m.seconds.back());
    }
  }
  const Measured& base = runs.front();  // the DBVT in use
  bool equal = true;
  nlohmann::json j = {{"bench", "broadphase"},
                      {"scene", o.scene},
                      {"n", o.params.n},
                      {"seed", o.params.seed},
                      {"bodies", scene.bodies.size()},
                      {"steps", o.steps},
                      {"repeat", o.repeat},
                      {"precision", kPrecisionName},
                      {"timing_contains", kTimingContains},
                      {"ratio_meaning", "ratio_vs_dbvt = dbvt seconds / this broadphase's seconds, > 1: faster than "
                                        "the DBVT in use"},
                      {"recording", recording_json(rec)}};
  for (const Measured& m : runs) {
    j["broadphases"].push_back(measured_json(m, base, o.steps, rec.stepping_seconds));
    equal = equal && first_difference(base, m) < 0;
  }
  if (rec.bodies.size() <= kBruteForceBodies) {
    const bool brute_equal = brute_force_hashes(rec) == base.checked.exact_hash;
    j["exact_pairs_equal_to_brute_force"] = brute_equal;
    equal = equal && brute_equal;
  }
  j["exact_pairs_equal"] = equal;
  std::string summary;
  for (const Measured& m : runs) {
    char part[160];
    std::snprintf(part, sizeof part, "%s%s %.4f s (ratio %.3f)", summary.empty() ? "" : ", ", m.kind.name.c_str(),
                  m.least(), base.least() / std::max(m.least(), 1e-12));
    summary += part;
  }
  std::fprintf(stderr, "broadphase bench, %s n=%d, %d steps, least of %d: %s; exact pairs equal: %s\n",
               o.scene.c_str(), o.params.n, o.steps, o.repeat, summary.c_str(), equal ? "yes" : "NO");
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  return equal ? 0 : 1;
}

}  // namespace

Command add_broadphase_command(CLI::App& bench) {
  auto o = std::make_shared<BroadphaseOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "broadphase",
      "The worlds' DBVT broadphase against an incremental sweep and prune (bt32BitAxisSweep3), a one-axis sort "
      "and sweep and Bullet's DBVT defaults, on a scene's awake bodies' boxes recorded from a stock world; exact "
      "pairs checked every step; JSON on stdout (docs/results/broadphase.md)");
  cmd->add_option("--scene", o->scene, "Registry scene name")->capture_default_str();
  cmd->add_option("--n", o->params.n, "Scene size (0: the scene's default)")
      ->check(CLI::Range(0, 1 << 24))
      ->capture_default_str();
  cmd->add_option("--seed", o->params.seed, "Seed of the scene generator")->capture_default_str();
  cmd->add_option("--steps", o->steps, "Steps recorded and replayed")->check(CLI::Range(1, 1 << 24))->capture_default_str();
  cmd->add_option("--repeat", o->repeat, "Interleaved timed replays of each broadphase (least and median reported)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  return {cmd, [o] { return run_broadphase(*o); }};
}

}  // namespace soda::cli
