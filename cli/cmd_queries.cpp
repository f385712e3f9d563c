// `soda bench queries` (docs/embedding.md, "Queries"): ray casts against a
// running Simulation. The scene (falling-cubes 16000 by default) runs on K
// territories (2) to a step S in two ways, interleaved over --repeat rounds:
// alone, and with a query thread that casts R rays per simulated second
// (100,000) at the committed frame of every step, straight down from a
// lattice over the bodies. Per round: the simulation's wall time to step S
// alone and with the queries, their ratio (alone / with: the baseline's time
// over ours, > 1 faster, < 1 the slowdown the queries cause), the query
// thread's rays per wall second and per CPU second of its own thread. JSON
// on stdout (and --out FILE), a summary on stderr; exit 1 if a run with
// queries ends on another state hash than the run without.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "commands.h"
#include "soda/bench/result_json.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

namespace {

struct QueriesOptions {
  std::string scene = "falling-cubes";
  SceneParams params{16000, 1, false};
  int territories = 2;
  int steps = 60;
  double rays_per_second = 100000;  // per simulated second
  int repeat = 3;
  std::string out;
};

struct QueryLoad {
  std::int64_t rays = 0;
  std::int64_t hits = 0;
  std::uint64_t checksum = 0;  // of every answer's step, ids and fractions: the same every round
  double wall_seconds = 0;     // from the first cast to the last answer
  double cpu_seconds = 0;      // the query thread's own CPU
};

struct Round {
  double alone_seconds = 0, with_seconds = 0;
  std::uint64_t alone_hash = 0, with_hash = 0;
  QueryLoad load;
};

// The rays of one step: a lattice of `count` vertical rays over the box
// [lo, hi] of the bodies at the start, shifted by a step-dependent offset
// so that consecutive steps do not cast the same rays.
struct RayLattice {
  Vec3 lo, hi;
  int count;
  Vec3 from(std::int64_t step, int i) const {
    const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count))));
    const double shift = 0.37 * static_cast<double>(step % 7) / 7.0;
    const double u = (static_cast<double>(i % side) + shift) / side, v = (static_cast<double>(i / side) + shift) / side;
    return {lo.x() + u * (hi.x() - lo.x()), hi.y() + 5.0, lo.z() + v * (hi.z() - lo.z())};
  }
};

double seconds_since(std::int64_t start_ns) { return static_cast<double>(wall_ns() - start_ns) * 1e-9; }

SimulationConfig config_of(const QueriesOptions& o) {
  SimulationConfig c;
  c.territories = o.territories;
  return c;
}

// The simulation alone: wall seconds to every world's step S.
double run_alone(const Scene& scene, const QueriesOptions& o, std::uint64_t& hash) {
  Simulation sim(scene, config_of(o));
  const std::int64_t a = wall_ns();
  sim.advance_to(sim.time_of(o.steps));
  const double t = seconds_since(a);
  hash = sim.state_hash();
  return t;
}

// The simulation with a query thread casting at every step 1..S.
double run_with_queries(const Scene& scene, const QueriesOptions& o, const RayLattice& rays, std::uint64_t& hash,
                        QueryLoad& load) {
  Simulation sim(scene, config_of(o));
  SceneQuery query = sim.add_query();
  std::thread caster([&] {
    const std::int64_t cpu0 = thread_cpu_ns(), wall0 = wall_ns();
    for (std::int64_t step = 1; step <= o.steps; ++step) {
      const double time = sim.time_of(step);
      for (int i = 0; i < rays.count; ++i) {
        const Vec3 from = rays.from(step, i);
        const std::optional<QueryResult<QueryHit>> hit = query.ray_cast(time, from, Vec3(from.x(), -5.0, from.z()));
        if (!hit) return;  // the simulation stopped (it does not here)
        ++load.rays;
        load.checksum = load.checksum * 1099511628211ull + static_cast<std::uint64_t>(hit->step);
        for (const QueryHit& h : hit->items) {
          ++load.hits;
          load.checksum = load.checksum * 1099511628211ull + h.id + static_cast<std::uint64_t>(h.fraction * 1e9);
        }
      }
    }
    load.wall_seconds = seconds_since(wall0);
    load.cpu_seconds = static_cast<double>(thread_cpu_ns() - cpu0) * 1e-9;
  });
  const std::int64_t a = wall_ns();
  sim.advance_to(sim.time_of(o.steps));
  const double t = seconds_since(a);
  caster.join();
  hash = sim.state_hash();
  return t;
}

int run_queries(const QueriesOptions& o) {
  const Scene scene = make_scene(o.scene, o.params);
  Vec3 lo = Vec3::Constant(1e30), hi = Vec3::Constant(-1e30);
  for (const Body& b : scene.bodies)
    if (!b.is_static) {
      lo = lo.cwiseMin(b.position);
      hi = hi.cwiseMax(b.position);
    }
  const int per_step = std::max(1, static_cast<int>(std::lround(o.rays_per_second * scene.settings.dt)));
  const RayLattice rays{lo, hi, per_step};
  std::fprintf(stderr, "queries bench: %s %d, %d territories, %d steps, %d rays per step (%.0f per simulated s), %d rounds\n",
               o.scene.c_str(), o.params.n, o.territories, o.steps, per_step, per_step / scene.settings.dt, o.repeat);
  std::vector<Round> rounds;
  bool same = true;
  for (int r = 0; r < o.repeat; ++r) {
    Round round;
    round.alone_seconds = run_alone(scene, o, round.alone_hash);
    round.with_seconds = run_with_queries(scene, o, rays, round.with_hash, round.load);
    same = same && round.alone_hash == round.with_hash &&
           (rounds.empty() || round.load.checksum == rounds.front().load.checksum);
    std::fprintf(stderr, "  round %d: alone %.3f s, with queries %.3f s (ratio %.3f); %lld rays, %lld hits, %.0f rays/s wall, %.0f rays per CPU s\n",
                 r + 1, round.alone_seconds, round.with_seconds, round.alone_seconds / round.with_seconds,
                 static_cast<long long>(round.load.rays), static_cast<long long>(round.load.hits),
                 round.load.rays / std::max(round.load.wall_seconds, 1e-9),
                 round.load.rays / std::max(round.load.cpu_seconds, 1e-9));
    rounds.push_back(round);
  }
  std::vector<double> ratio, per_wall, per_cpu;
  nlohmann::json rows = nlohmann::json::array();
  for (const Round& r : rounds) {
    ratio.push_back(r.alone_seconds / r.with_seconds);
    per_wall.push_back(r.load.rays / std::max(r.load.wall_seconds, 1e-9));
    per_cpu.push_back(r.load.rays / std::max(r.load.cpu_seconds, 1e-9));
    rows.push_back({{"alone_seconds", r.alone_seconds},
                    {"with_queries_seconds", r.with_seconds},
                    {"ratio_vs_alone", r.alone_seconds / r.with_seconds},
                    {"rays", r.load.rays},
                    {"hits", r.load.hits},
                    {"query_wall_seconds", r.load.wall_seconds},
                    {"query_thread_cpu_seconds", r.load.cpu_seconds},
                    {"state_hash_alone", hash_hex(r.alone_hash)},
                    {"state_hash_with_queries", hash_hex(r.with_hash)}});
  }
  const double simulated = o.steps * scene.settings.dt;
  nlohmann::json j = {
      {"bench", "queries"},
      {"scene", o.scene},
      {"n", o.params.n},
      {"territories", o.territories},
      {"steps", o.steps},
      {"simulated_seconds", simulated},
      {"rays_per_step", per_step},
      {"rays_per_simulated_second", per_step / scene.settings.dt},
      {"hardware_threads", std::thread::hardware_concurrency()},
      {"ratio_vs_alone_median", median(ratio)},
      {"ratio_vs_alone_meaning",
       "the simulation's wall time to the last step alone / with the query thread (> 1 faster; < 1: the queries "
       "slow it down); the query thread shares the machine's cores with the worlds"},
      {"rays_per_wall_second_median", median(per_wall)},
      {"rays_per_query_thread_cpu_second_median", median(per_cpu)},
      {"hashes_equal", same},
      {"rounds", rows}};
  std::fprintf(stderr, "  median: ratio %.3f (alone / with queries), %.0f rays per wall s, %.0f rays per query-thread CPU s%s\n",
               median(ratio), median(per_wall), median(per_cpu), same ? "" : "; STATE HASHES DIFFER");
  write_json(j, "-");
  if (!o.out.empty()) write_json(j, o.out);
  return same ? 0 : 1;
}

}  // namespace

Command add_queries_command(CLI::App& bench) {
  auto o = std::make_shared<QueriesOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "queries",
      "Ray casts against a running Simulation: the simulation's time alone and with a query thread casting "
      "--rays per simulated second at every committed step (ratio_vs_alone), rays per second; JSON on stdout");
  cmd->add_option("--scene", o->scene, "Registry scene")->capture_default_str();
  cmd->add_option("--n", o->params.n, "The scene's N")->check(CLI::Range(1, 1 << 22))->capture_default_str();
  cmd->add_option("--territories", o->territories, "Territories (a thread each)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--steps", o->steps, "Scene steps of every run")->check(CLI::Range(1, 1 << 20))->capture_default_str();
  cmd->add_option("--rays", o->rays_per_second, "Rays per simulated second (rounded to whole rays per step)")
      ->check(CLI::Range(1.0, 1e9))
      ->capture_default_str();
  cmd->add_option("--repeat", o->repeat, "Rounds (alone, then with queries, interleaved); medians reported")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--out", o->out, "Also write the JSON to this file");
  return {cmd, [o] { return run_queries(*o); }};
}

}  // namespace soda::cli
