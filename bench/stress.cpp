// The stress suite (stress.h). Pass criteria: docs/stress.md.
#include "soda/bench/stress.h"
#include "soda/bench/csv.h"
#include "soda/bench/stress_joints.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <tuple>
#include <set>
#include <sstream>

#include <btBulletDynamicsCommon.h>
#include <spdlog/spdlog.h>

#include "soda/bench/accuracy.h"
#include "soda/bench/solver_variant.h"
#include "soda/grid/partition.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "soda/worlds/stock_world.h"
#include "soda/worlds/watchdog.h"

namespace soda {
namespace {

constexpr double kStandTolerance = 0.1;  // m: a tenth of the unit box's edge
constexpr double kSmallStandTolerance = 0.025;  // m: half the edge of mixed-sizes' small boxes
constexpr int kEarlySteps = 30;          // far-origin: 0.5 s of trajectory compared with the origin pile

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

Vec3 sample_position(const BodySample& s) { return {s.position[0], s.position[1], s.position[2]}; }
Vec3 sample_velocity(const BodySample& s) { return {s.linear_velocity[0], s.linear_velocity[1], s.linear_velocity[2]}; }

// What a case's criterion may look at, gathered over every step.
struct Observed {
  std::vector<BodySample> initial, final;
  std::vector<int> final_activation;     // Bullet activation state per dynamic body at the end
  std::vector<std::vector<BodySample>> early;  // states after steps 1..kEarlySteps
  int settle_step = -1;  // first step at which every body still on the ground (y > -1 m) is asleep
  std::vector<BodySample> at_settle;  // states at settle_step
  double drift_after_settle = 0;      // m, max displacement from at_settle to the end
  std::vector<double> max_displacement;  // per body, m, from the initial position, over the run
  std::vector<double> max_x;             // per body, m
  double min_y = std::numeric_limits<double>::infinity();  // lowest body centre over the run
  double energy0 = 0, energy_max = 0, energy_end = 0;
  double energy_max_after_settle = -std::numeric_limits<double>::infinity();  // over the second half
  double energy_at_half = 0;
  double max_speed_end = 0;
  PenetrationStats penetration;
  std::int64_t nonfinite_step = -1;
  std::int64_t watchdog_step = -1;  // canonical world: first step the watchdog (default limits, stop) objected to
  std::string watchdog_text;
  int steps_run = 0;
  double wall_seconds = 0;
  std::size_t sleeping = 0;
  std::uint64_t hash = 0;
  std::size_t dynamic = 0;
};

template <class W>
Observed observe(W& world, const Scene& scene, int steps) {
  Observed o;
  const EnergyTable energy(scene);
  btDispatcher& dispatcher = *world.bullet().getDispatcher();
  std::set<BodyId> statics;
  for (const Body& b : scene.bodies)
    if (b.is_static) statics.insert(b.id);
  o.initial = to_samples(scene, world.body_states());
  o.dynamic = o.initial.size();
  o.max_displacement.assign(o.initial.size(), 0.0);
  o.max_x.resize(o.initial.size());
  for (std::size_t i = 0; i < o.initial.size(); ++i) {
    o.max_x[i] = o.initial[i].position[0];
    o.min_y = std::min(o.min_y, o.initial[i].position[1]);
  }
  o.energy0 = o.energy_max = o.energy_end = energy.energy(o.initial);
  std::vector<BodySample> now = o.initial;
  for (int k = 1; k <= steps; ++k) {
    const std::int64_t a = wall_ns();
    world.step();
    o.wall_seconds += static_cast<double>(wall_ns() - a) * 1e-9;
    o.steps_run = k;
    const std::vector<BodyState> raw = world.body_states();
    if (!std::all_of(raw.begin(), raw.end(), is_finite)) {
      o.nonfinite_step = k;  // the defined response: stop here and fail the case
      break;
    }
    if constexpr (requires { world.watchdog_findings(WatchdogLimits{}); }) {
      // The watchdog runs in every case, as `soda run` does by default
      // (stop); the stock world is not checked (docs/watchdog.md).
      const WatchdogLimits limits;
      const std::vector<WatchdogFinding> findings = world.watchdog_findings(limits);
      if (!findings.empty()) {
        o.watchdog_step = k;
        o.watchdog_text = describe(findings.front(), limits);
        break;
      }
    }
    o.penetration.add(manifold_penetration(dispatcher));
    now = to_samples(scene, raw);
    if (k <= kEarlySteps) o.early.push_back(now);
    if (o.settle_step < 0) {
      bool all = true;
      for (const BodyState& b : raw)
        if (!statics.count(b.id) && static_cast<double>(b.origin[1]) > -1.0 && b.activation_state != ISLAND_SLEEPING) {
          all = false;
          break;
        }
      if (all) {
        o.settle_step = k;
        o.at_settle = now;
      }
    }
    for (std::size_t i = 0; i < now.size(); ++i) {
      o.max_displacement[i] = std::max(o.max_displacement[i], (sample_position(now[i]) - sample_position(o.initial[i])).norm());
      o.max_x[i] = std::max(o.max_x[i], now[i].position[0]);
      o.min_y = std::min(o.min_y, now[i].position[1]);
    }
    const double e = energy.energy(now);
    o.energy_max = std::max(o.energy_max, e);
    if (k == steps / 2) o.energy_at_half = e;
    if (k > steps / 2) o.energy_max_after_settle = std::max(o.energy_max_after_settle, e);
    o.energy_end = e;
  }
  o.final = now;
  for (std::size_t i = 0; i < o.at_settle.size() && i < o.final.size(); ++i)
    o.drift_after_settle = std::max(o.drift_after_settle, (sample_position(o.final[i]) - sample_position(o.at_settle[i])).norm());
  {
    std::map<BodyId, int> activation;
    for (const BodyState& b : world.body_states()) activation[b.id] = b.activation_state;
    for (const BodySample& b : o.final) o.final_activation.push_back(activation.at(b.id));
  }
  for (const BodySample& s : o.final) o.max_speed_end = std::max(o.max_speed_end, sample_velocity(s).norm());
  o.sleeping = world.sleeping_count();
  o.hash = world.state_hash();
  return o;
}

Observed run_case_world(const Scene& scene, const StressCase& c) {
  if (c.world == WorldKind::Stock) {
    std::unique_ptr<btConstraintSolver> variant_solver;  // outlives the world
    StockWorld w(scene);
    apply_solver_variant(w.bullet(), c.variant, variant_solver);
    if (c.ccd) enable_ccd(w.bullet(), scene);
    return observe(w, scene, c.steps);
  }
  if (c.ccd) throw std::invalid_argument("CCD is outside the canonical world's contract");
  std::unique_ptr<btConstraintSolver> variant_solver;  // outlives the world
  CanonicalWorld w(scene);
  if (c.solver_threads > 1) w.set_solver_pool(std::make_shared<SolverPool>(c.solver_threads));
  apply_solver_variant(w.bullet(), c.variant, variant_solver);
  return observe(w, scene, c.steps);
}

void verdict(StressResult& r, bool pass, double metric, double threshold, std::string measured) {
  r.status = pass ? "pass" : "FAIL";
  r.metric = metric;
  r.threshold = threshold;
  r.measured = std::move(measured);
}

std::string energy_text(const Observed& o) {
  return "E_max - E_0 = " + fmt("%.3g", o.energy_max - o.energy0) + " J (E_0 " + fmt("%.4g", o.energy0) + " J)";
}

// Stands: no box moves more than kStandTolerance from where it started.
void stands(StressResult& r, const Observed& o, double tolerance = kStandTolerance) {
  const auto it = std::max_element(o.max_displacement.begin(), o.max_displacement.end());
  const double worst = *it;
  const std::size_t i = static_cast<std::size_t>(it - o.max_displacement.begin());
  const Vec3 top_shift = sample_position(o.final.back()) - sample_position(o.initial.back());
  verdict(r, worst <= tolerance, worst, tolerance,
          "max displacement " + fmt("%.4g", worst) + " m (body " + std::to_string(o.initial[i].id) +
              "); top body moved (" + fmt("%.3g", top_shift.x()) + ", " + fmt("%.3g", top_shift.y()) + ", " +
              fmt("%.3g", top_shift.z()) + ") m; max penetration " + fmt("%.3g", o.penetration.max) + " m; " +
              std::to_string(o.sleeping) + "/" + std::to_string(o.dynamic) + " asleep");
}

// Bodies asleep among those still on the ground (centre above y = -1 m),
// and how many fell off its edge.
std::pair<std::size_t, std::size_t> asleep_on_ground(const Observed& o, std::size_t& on_ground) {
  std::size_t asleep = 0, fell = 0;
  on_ground = 0;
  for (std::size_t i = 0; i < o.final.size(); ++i) {
    if (o.final[i].position[1] < -1.0) {
      ++fell;
      continue;
    }
    ++on_ground;
    if (o.final_activation[i] == ISLAND_SLEEPING) ++asleep;
  }
  return {asleep, fell};
}

// The origin pile a far-origin case is compared with: cube-pile n = 50, same
// seed, same precision and world (cached per process).
// The scene of a case, with its dt / iterations overrides.
Scene case_scene(const StressCase& c, const std::string& name, int n) {
  Scene scene = make_scene(name, {n, 1, false});
  if (c.dt > 0) scene.settings.dt = c.dt;
  if (c.iterations > 0) scene.settings.iterations = c.iterations;
  if (c.substeps > 0) scene.settings.substeps = c.substeps;
  return scene;
}

const Observed& origin_pile(const StressCase& far) {
  static std::map<std::tuple<int, double, int>, Observed> cache;
  const auto key = std::make_tuple(far.steps, far.dt, far.iterations);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  StressCase c = far;
  c.world = WorldKind::Canonical;
  c.ccd = false;
  return cache.emplace(key, run_case_world(case_scene(c, "cube-pile", 50), c)).first->second;
}

}  // namespace

StressCase with_settings(StressCase c, double dt, int iterations) {
  if (dt > 0) {
    const double base = c.dt > 0 ? c.dt : make_scene(c.scene, {c.n, 1, false}).settings.dt;
    c.steps = static_cast<int>(std::lround(c.steps * base / dt));
    c.dt = dt;
  }
  if (iterations > 0) c.iterations = iterations;
  return c;
}

std::vector<StressCase> stress_suite(bool quick) {
  std::vector<StressCase> s;
  const int stand_steps = quick ? 120 : 3600;  // 60 s
  const std::string stands_text = "stands " + std::string(quick ? "2" : "60") +
                                  " s: no box moves more than 0.1 m (a tenth of its edge) from its start";
  for (int k : {10, 20, 30})
    s.push_back({"tower-" + std::to_string(k), "tower", "tower", k, stand_steps, WorldKind::Canonical, false, false,
                 stands_text});
  for (int k : {20, 30})
    s.push_back({"pyramid-" + std::to_string(k), "pyramid", "pyramid", k, stand_steps, WorldKind::Canonical, false,
                 false, stands_text});
  for (int k : {10, 100, 1000})
    s.push_back({"mass-ratio-1:" + std::to_string(k), "mass-ratio", "mass-ratio", k, stand_steps,
                 WorldKind::Canonical, false, false, stands_text});
  s.push_back({"tower-50", "tower", "tower", 50, stand_steps, WorldKind::Canonical, false, false, stands_text});
  s.push_back({"card-house-5", "card-house", "card-house", 5, stand_steps, WorldKind::Canonical, false, false,
               stands_text});
  s.push_back({"heavy-drop-10", "heavy-drop", "heavy-drop", 10, quick ? 120 : 600, WorldKind::Canonical, false, false,
               "a 100 kg box dropped 1 m onto a tower of ten 1 kg boxes: no tower box moves more than 0.1 m "
               "sideways, the heavy box ends on top (centre within 0.1 m of 10.5 m)"});
  s.push_back({"sphere-chain-100", "sphere-chain", "sphere-chain", 100, quick ? 120 : 600, WorldKind::Canonical,
               false, false,
               "100 touching spheres, the first pushed at 5 m/s: no energy gain (E never above E_0), max "
               "penetration < 0.05 m (a tenth of the radius), every sphere stays on the ground and on the line "
               "(centre y >= 0.45 m, |z| < 0.1 m)"});
  s.push_back({"mixed-sizes-5", "mixed-sizes", "mixed-sizes", 5, stand_steps, WorldKind::Canonical, false, false,
               "a 10 m box with 25 boxes of 0.05 m on it and 25 beside it: no body moves more than 0.025 m (half "
               "the small edge) from its start"});
  s.push_back({"plank-pile-8", "plank-pile", "plank-pile", 8, 600, WorldKind::Canonical, false, false,
               "an 8 m plank of 40 kg dropped end first from 0.5 m onto a 4 x 4 x 3 pile of 1 kg cubes, 10 s: it "
               "comes to rest on the pile (centre above the pile's top face, y >= 3 m; speed < 0.01 m/s at the "
               "end), no body below the ground, max penetration < 0.05 m (a quarter of the plank's thickness), no "
               "energy gain (E never above E_0)"});
  s.push_back({"heavy-slide-6", "heavy-slide", "heavy-slide", 6, 300, WorldKind::Canonical, false, false,
               "a 5 m box of 10 t sliding at 6 m/s across the borders of grid:Kx1x1, K = 1, 2, 4, 8, into two rows "
               "of unit cubes, 5 s: the same state hash for every K; friction stops it (speed < 0.01 m/s at the "
               "end, never faster than its start), it never sinks into the ground by 0.05 m (centre y >= 2.45 m) "
               "and no cube goes below the ground (centre y >= 0.45 m)"});
  const std::string wall_text = "the sphere is stopped by the wall: its centre never passes x = 0 (the wall's mid-plane)";
  for (int v : {50, 200, 500}) {
    const std::string base = "bullet-" + std::to_string(v);
    s.push_back({base + "-canonical", "bullet-vs-wall", "bullet-vs-wall", v, 120, WorldKind::Canonical, false,
                 false, wall_text});
    s.push_back({base + "-stock", "bullet-vs-wall", "bullet-vs-wall", v, 120, WorldKind::Stock, false, false,
                 wall_text});
    s.push_back({base + "-stock-ccd", "bullet-vs-wall", "bullet-vs-wall", v, 120, WorldKind::Stock, true, false,
                 wall_text});
  }
  s.push_back({"bullet-border-200", "bullet-border", "bullet-vs-wall", 200, 120, WorldKind::Canonical, false, false,
               "bullet-vs-wall at 200 m/s on grid:Kx1x1 maps of 2 m cells (the wall's mid-plane on a border), K = "
               "1, 2, 4, 8: stopped by the wall (as bullet-vs-wall) and the same state hash for every K"});
  const std::string far_text =
      "settles as the same pile at the origin does (cube-pile n=50, same precision): every cube still on the "
      "ground asleep within 20 s, mean penetration at most 2x the origin pile's + 1 mm";
  // far-origin keeps its 20 s in --quick too: its criterion is settling,
  // which takes 6-11 s (docs/stress.md), and 2 s could only ever fail; the
  // whole case costs about 0.1 s of CPU.
  for (int d : {1000, 10000, 100000})
    s.push_back({"far-origin-1e" + std::to_string(static_cast<int>(std::lround(std::log10(d)))), "far-origin",
                 "far-origin", d, 1200, WorldKind::Canonical, false, true, far_text});
  add_joint_stress_cases(s, quick);
  s.push_back({"dense-pile-" + std::to_string(quick ? 200 : 1000), "dense-pile", "dense-pile", quick ? 200 : 1000,
               quick ? 60 : 600, WorldKind::Canonical, false, false,
               "contained and stable: every cube stays in the bin (|x|, |z| < 2 m, centre above the ground), max "
               "penetration < 0.125 m (a quarter of the 0.5 m edge), no energy gain (E never above E_0)"});
  s.push_back({"long-run", "long-run", "cube-pile", 100, quick ? 2000 : 100000, WorldKind::Canonical, false, false,
               "1e5 steps (27.8 min simulated) of cube-pile n=100: finite throughout, settles, then no body moves "
               "at all (sleeping bodies stay put: displacement exactly 0), no energy gain over the second half "
               "(+1 mJ), no body below the ground, every cube asleep at the end"});
  return s;
}

// Runs `scene` on grid:Kx1x1 maps for K = 1, 2, 4, 8, calling `observe(k,
// t, world)` after every step t (0-based); adds the wall time to r and
// returns whether every K gave the one-territory hash, with the hashes in
// words.
template <class Observe>
std::pair<bool, std::string> run_on_slabs(StressResult& r, const Scene& scene, const StressCase& c,
                                          const GridOptions& grid, Observe observe) {
  std::string hashes;
  std::uint64_t first = 0;
  bool same = true;
  for (int k : {1, 2, 4, 8}) {
    PartitionedOptions options;
    options.runtime.solver_threads = c.solver_threads;
    PartitionedWorld w(scene, make_partition("grid:" + std::to_string(k) + "x1x1", scene, k, grid), options);
    const std::int64_t a = wall_ns();
    for (int t = 0; t < c.steps; ++t) {
      w.step(1);
      observe(k, t, w);
    }
    r.wall_seconds += static_cast<double>(wall_ns() - a) * 1e-9;
    const std::uint64_t h = w.state_hash();
    if (k == 1) first = h;
    same = same && h == first;
    hashes += (hashes.empty() ? "" : ", ") + std::string("K=") + std::to_string(k) + " " + hash_hex(h);
  }
  r.steps_run = c.steps;
  r.state_hash = hash_hex(first);
  return {same, hashes};
}

// bullet-border: the same scene on grid:Kx1x1 maps, K = 1, 2, 4, 8.
void run_bullet_border(StressResult& r, const Scene& scene, const StressCase& c) {
  GridOptions grid;
  grid.cell_size = 2.0;  // the wall's mid-plane x = 0 is a border for every K
  grid.origin = Vec3::Zero();
  grid.box = CellBox{{-8, 0, -1}, {7, 1, 0}};  // x in [-16, 16]: slabs of 16 / K cells
  double max_x = -std::numeric_limits<double>::infinity();
  const BodyId sphere = scene.bodies.back().id;
  const auto [same, hashes] = run_on_slabs(r, scene, c, grid, [&](int, int, const PartitionedWorld& w) {
    for (const BodyState& b : w.body_states())
      if (b.id == sphere) max_x = std::max(max_x, double(b.origin[0]));
  });
  verdict(r, max_x < 0.0 && same, max_x, 0.0,
          "sphere max x " + fmt("%.4g", max_x) + " m" + (max_x < 0.0 ? " (stopped)" : " (passed through)") +
              "; state hashes " + (same ? "equal" : "DIFFER") + " (" + hashes + ")");
}

// heavy-slide: the scene on grid:Kx1x1 maps over its default grid, K = 1,
// 2, 4, 8 (the box's path crosses the borders of every K > 1).
void run_heavy_slide(StressResult& r, const Scene& scene, const StressCase& c) {
  const BodyId box = 1;  // the 5 m box; every other dynamic body is a unit cube
  const double start_speed = scene.bodies[1].linear_velocity.norm();
  std::set<BodyId> statics;
  for (const Body& b : scene.bodies)
    if (b.is_static) statics.insert(b.id);
  double box_min_y = std::numeric_limits<double>::infinity(), cube_min_y = box_min_y, box_max_speed = 0;
  double end_speed = 0, end_x = 0;
  const auto [same, hashes] = run_on_slabs(r, scene, c, GridOptions{}, [&](int k, int t, const PartitionedWorld& w) {
    for (const BodyState& b : w.body_states()) {
      const double y = b.origin[1];
      if (b.id == box) {
        box_min_y = std::min(box_min_y, y);
        const double v = Vec3(b.linear_velocity[0], b.linear_velocity[1], b.linear_velocity[2]).norm();
        box_max_speed = std::max(box_max_speed, v);
        if (t + 1 == c.steps && k == 1) {
          end_speed = v;
          end_x = b.origin[0];
        }
      } else if (!statics.count(b.id)) {
        cube_min_y = std::min(cube_min_y, y);
      }
    }
  });
  const double sink = 2.5 - box_min_y;
  const bool pass = same && end_speed < 0.01 && box_max_speed <= start_speed + 1e-6 && box_min_y >= 2.45 &&
                    cube_min_y >= 0.45;
  verdict(r, pass, sink, 0.05,
          "box stops at x " + fmt("%.4g", end_x) + " m (speed at the end " + fmt("%.3g", end_speed) +
              " m/s, fastest " + fmt("%.4g", box_max_speed) + " m/s); sank at most " + fmt("%.3g", sink) +
              " m; lowest cube centre " + fmt("%.4g", cube_min_y) + " m; state hashes " + (same ? "equal" : "DIFFER") +
              " (" + hashes + ")");
}

StressResult run_stress_case(const StressCase& c) {
  StressResult r;
  r.c = c;
  r.precision = kPrecisionName;
  try {
    const Scene scene = case_scene(c, c.scene, c.n);
    r.c.dt = scene.settings.dt;  // report the settings used
    r.c.iterations = scene.settings.iterations;
    r.c.substeps = scene.settings.substeps;
    if (c.group == "bullet-border") {
      run_bullet_border(r, scene, c);
      return r;
    }
    if (c.group == "heavy-slide") {
      run_heavy_slide(r, scene, c);
      return r;
    }
    if (is_joint_stress_group(c.group)) {
      run_joint_stress_case(r, scene, c);
      return r;
    }
    const Observed o = run_case_world(scene, c);
    r.steps_run = o.steps_run;
    r.wall_seconds = o.wall_seconds;
    r.sleeping = o.sleeping;
    r.state_hash = hash_hex(o.hash);
    if (o.watchdog_step >= 0) {
      verdict(r, false, std::numeric_limits<double>::quiet_NaN(), 0,
              "watchdog: step " + std::to_string(o.watchdog_step) + ": " + o.watchdog_text + ": stopped");
      return r;
    }
    if (o.nonfinite_step >= 0) {
      verdict(r, false, std::numeric_limits<double>::quiet_NaN(), 0,
              "non-finite state at step " + std::to_string(o.nonfinite_step) + ": stopped");
      return r;
    }
    if (c.group == "tower" || c.group == "pyramid" || c.group == "mass-ratio" || c.group == "card-house") {
      stands(r, o);
    } else if (c.group == "mixed-sizes") {
      stands(r, o, kSmallStandTolerance);
    } else if (c.group == "heavy-drop") {
      double sideways = 0;
      for (std::size_t i = 0; i + 1 < o.final.size(); ++i) {
        const Vec3 d = sample_position(o.final[i]) - sample_position(o.initial[i]);
        sideways = std::max(sideways, std::hypot(d.x(), d.z()));
      }
      const double top = o.final.back().position[1], want = c.n + 0.5;
      verdict(r, sideways <= kStandTolerance && std::abs(top - want) <= kStandTolerance, sideways, kStandTolerance,
              "largest sideways move of a tower box " + fmt("%.4g", sideways) + " m; heavy box ends at y " +
                  fmt("%.4g", top) + " m (on top: " + fmt("%.4g", want) + "); max penetration " +
                  fmt("%.3g", o.penetration.max) + " m; " + std::to_string(o.sleeping) + "/" +
                  std::to_string(o.dynamic) + " asleep");
    } else if (c.group == "plank-pile") {
      const BodySample& plank = o.final.back();  // the plank is the last body
      const double speed = sample_velocity(plank).norm();
      const bool pass = plank.position[1] >= 3.0 && speed < 0.01 && o.min_y > 0.0 && o.penetration.max < 0.05 &&
                        o.energy_max <= o.energy0;
      verdict(r, pass, o.penetration.max, 0.05,
              "plank ends at y " + fmt("%.4g", plank.position[1]) + " m (pile top 3 m), speed " +
                  fmt("%.3g", speed) + " m/s; lowest centre " + fmt("%.4g", o.min_y) + " m; max penetration " +
                  fmt("%.3g", o.penetration.max) + " m; " + energy_text(o) + "; " + std::to_string(o.sleeping) +
                  "/" + std::to_string(o.dynamic) + " asleep");
    } else if (c.group == "sphere-chain") {
      double off_line = 0;
      for (const BodySample& b : o.final) off_line = std::max(off_line, std::abs(b.position[2]));
      const bool pass = o.energy_max <= o.energy0 && o.penetration.max < 0.05 && o.min_y >= 0.45 && off_line < 0.1;
      verdict(r, pass, o.penetration.max, 0.05,
              "max penetration " + fmt("%.3g", o.penetration.max) + " m; " + energy_text(o) +
                  "; lowest centre " + fmt("%.4g", o.min_y) + " m; largest |z| at the end " + fmt("%.3g", off_line) +
                  " m; first sphere at x " + fmt("%.4g", o.final.front().position[0]) + " m, last at x " +
                  fmt("%.4g", o.final.back().position[0]) + " m");
    } else if (c.group == "bullet-vs-wall") {
      const double x = o.max_x.back();  // the sphere is the only dynamic body
      verdict(r, x < 0.0, x, 0.0,
              "sphere max x " + fmt("%.4g", x) + " m, final x " + fmt("%.4g", o.final.back().position[0]) +
                  " m" + (x < 0.0 ? " (stopped)" : " (passed through)"));
    } else if (c.group == "far-origin") {
      const Observed& origin = origin_pile(c);
      std::size_t on_ground = 0, origin_on_ground = 0;
      const auto [asleep, fell] = asleep_on_ground(o, on_ground);
      const auto [origin_asleep, origin_fell] = asleep_on_ground(origin, origin_on_ground);
      const double pen_limit = 2.0 * origin.penetration.mean() + 0.001;
      const bool pass = o.settle_step > 0 && o.penetration.mean() <= pen_limit;
      // For information: deviation from the origin pile over the first 0.5 s
      // (offset removed) and the final centre of mass (chaotic).
      double sq = 0;
      std::size_t count = 0;
      for (std::size_t k = 0; k < std::min(o.early.size(), origin.early.size()); ++k)
        for (std::size_t i = 0; i < o.early[k].size(); ++i) {
          const Vec3 d = sample_position(o.early[k][i]) - Vec3(c.n, 0, 0) - sample_position(origin.early[k][i]);
          sq += d.squaredNorm();
          ++count;
        }
      const double early_rms = count ? std::sqrt(sq / static_cast<double>(count)) : 0.0;
      // Centres of mass of the cubes still on the ground.
      auto on_ground_only = [](const std::vector<BodySample>& v) {
        std::vector<BodySample> out;
        for (const BodySample& b : v)
          if (b.position[1] > -1.0) out.push_back(b);
        return out;
      };
      Vec3 com = centre_of_mass(scene, on_ground_only(o.final));
      com.x() -= c.n;
      const Vec3 com0 = centre_of_mass(make_scene("cube-pile", {50, 1, false}), on_ground_only(origin.final));
      const double dt = scene.settings.dt;
      auto settle = [dt](int step) { return step > 0 ? fmt("%.2f s", step * dt) : std::string("never"); };
      verdict(r, pass, o.settle_step > 0 ? o.settle_step * dt : std::numeric_limits<double>::infinity(),
              c.steps * dt,
              "settled at " + settle(o.settle_step) + " (origin pile " + settle(origin.settle_step) + ")" +
                  (fell ? ", " + std::to_string(fell) + " cube slid off the ground's edge" : std::string()) +
                  "; mean penetration " + fmt("%.3g", o.penetration.mean()) + " m (limit " +
                  fmt("%.3g", pen_limit) + "); for information: RMS deviation from the origin pile over 0.5 s " +
                  fmt("%.3g", early_rms) + " m, final |COM - COM_origin| (cubes on the ground) " +
                  fmt("%.3g", (com - com0).norm()) + " m");
      (void)asleep;
      (void)origin_asleep;
      (void)origin_fell;
    } else if (c.group == "dense-pile") {
      std::size_t outside = 0;
      double reach = 0;
      for (const BodySample& b : o.final) {
        reach = std::max({reach, std::abs(b.position[0]), std::abs(b.position[2])});
        if (std::abs(b.position[0]) >= 2.0 || std::abs(b.position[2]) >= 2.0 || b.position[1] <= 0.0) ++outside;
      }
      const bool inside = outside == 0 && o.min_y > 0.0;
      const bool no_gain = o.energy_max <= o.energy0;
      const bool pass = inside && o.penetration.max < 0.125 && no_gain;
      verdict(r, pass, o.penetration.max, 0.125,
              std::to_string(outside) + " cubes outside the bin at the end (largest |x|,|z| " + fmt("%.3g", reach) +
                  " m, lowest centre over the run " + fmt("%.3g", o.min_y) + " m); max penetration " +
                  fmt("%.3g", o.penetration.max) + " m, mean " + fmt("%.3g", o.penetration.mean()) + " m; " +
                  energy_text(o) + "; " + std::to_string(o.sleeping) + "/" + std::to_string(o.dynamic) + " asleep");
    } else if (c.group == "long-run") {
      const double gain = o.energy_max_after_settle - o.energy_at_half;
      const bool pass = o.min_y > 0.0 && gain <= 1e-3 && o.settle_step > 0 && o.drift_after_settle == 0.0 &&
                        o.sleeping == o.dynamic;
      verdict(r, pass, o.drift_after_settle, 0.0,
              "settled at " +
                  (o.settle_step > 0 ? fmt("%.2f s", o.settle_step * scene.settings.dt) : std::string("never")) +
                  ", then moved " + fmt("%.3g", o.drift_after_settle) + " m in " +
                  std::to_string(o.steps_run - std::max(o.settle_step, 0)) + " steps; E gain over the second half " +
                  fmt("%.3g", gain) + " J; lowest centre " + fmt("%.3g", o.min_y) + " m; " +
                  std::to_string(o.sleeping) + "/" + std::to_string(o.dynamic) + " asleep at the end; " +
                  fmt("%.0f", o.steps_run / std::max(o.wall_seconds, 1e-9)) + " steps/s");
    } else {
      r.status = "error";
      r.measured = "unknown group " + c.group;
    }
  } catch (const std::exception& e) {
    r.status = "error";
    r.measured = e.what();
  }
  return r;
}


std::string stress_csv_header() {
  return "case,group,scene,n,world,ccd,precision,dt,iterations,steps,steps_run,wall_seconds,result,metric,threshold,sleeping,"
         "state_hash,measured,criterion";
}

std::string stress_csv_row(const StressResult& r) {
  std::ostringstream s;
  s << csv_field(r.c.name) << ',' << r.c.group << ',' << r.c.scene << ',' << r.c.n << ','
    << world_kind_name(r.c.world) << ',' << (r.c.ccd ? "on" : "off") << ',' << r.precision << ','
    << fmt("%.17g", r.c.dt) << ',' << r.c.iterations << ',' << r.c.steps
    << ',' << r.steps_run << ',' << fmt("%.4g", r.wall_seconds) << ',' << r.status << ','
    << (std::isfinite(r.metric) ? fmt("%.6g", r.metric) : std::string()) << ',' << fmt("%.6g", r.threshold) << ',' << r.sleeping << ',' << r.state_hash << ','
    << csv_field(r.measured) << ',' << csv_field(r.c.criterion);
  return s.str();
}

nlohmann::json stress_json(const StressResult& r) {
  return {{"case", r.c.name},        {"group", r.c.group},         {"scene", r.c.scene},
          {"n", r.c.n},              {"steps", r.c.steps},         {"world", world_kind_name(r.c.world)},
          {"ccd", r.c.ccd},          {"both_precisions", r.c.both_precisions},
          {"criterion", r.c.criterion}, {"precision", r.precision}, {"status", r.status},
          {"measured", r.measured},  {"metric", std::isfinite(r.metric) ? nlohmann::json(r.metric) : nlohmann::json()},
          {"threshold", r.threshold}, {"steps_run", r.steps_run},  {"wall_seconds", r.wall_seconds},
          {"sleeping", r.sleeping},  {"state_hash", r.state_hash}, {"dt", r.c.dt},
          {"iterations", r.c.iterations}, {"substeps", r.c.substeps}};
}

StressResult stress_from_json(const nlohmann::json& j) {
  StressResult r;
  r.c.name = j.at("case");
  r.c.group = j.at("group");
  r.c.scene = j.at("scene");
  r.c.n = j.at("n");
  r.c.steps = j.at("steps");
  r.c.world = j.at("world") == "stock" ? WorldKind::Stock : WorldKind::Canonical;
  r.c.ccd = j.at("ccd");
  r.c.both_precisions = j.at("both_precisions");
  r.c.criterion = j.at("criterion");
  r.precision = j.at("precision");
  r.status = j.at("status");
  r.measured = j.at("measured");
  r.metric = j.at("metric").is_null() ? std::numeric_limits<double>::quiet_NaN() : j.at("metric").get<double>();
  r.threshold = j.at("threshold");
  r.steps_run = j.at("steps_run");
  r.wall_seconds = j.at("wall_seconds");
  r.sleeping = j.at("sleeping");
  r.state_hash = j.at("state_hash");
  r.c.dt = j.at("dt");
  r.c.iterations = j.at("iterations");
  r.c.substeps = j.value("substeps", 0);
  return r;
}

StressTally stress_tally(const std::vector<StressResult>& results) {
  StressTally t;
  for (const StressResult& r : results) {
    const bool stock = r.c.world == WorldKind::Stock;
    int& count = r.status == "pass" ? (stock ? t.stock_pass : t.pass)
                 : r.status == "FAIL" ? (stock ? t.stock_fail : t.fail)
                                      : (stock ? t.stock_other : t.other);
    ++count;
  }
  return t;
}

int stress_exit_status(const StressTally& t) { return t.fail + t.other + t.stock_other == 0 ? 0 : 1; }

std::string stress_tally_text(const StressTally& t) {
  return "SODA: " + std::to_string(t.pass) + " pass, " + std::to_string(t.fail) + " FAIL, " +
         std::to_string(t.other) + " other; stock Bullet (comparison rows, not SODA cases): " +
         std::to_string(t.stock_pass) + " pass, " + std::to_string(t.stock_fail) + " FAIL, " +
         std::to_string(t.stock_other) + " other";
}

std::string stress_markdown(const std::vector<StressResult>& results) {
  auto cell = [](const std::string& text) {  // a '|' would end the table cell
    std::string out;
    for (char ch : text) {
      if (ch == '|') out += '\\';
      out += ch;
    }
    return out;
  };
  std::ostringstream s;
  s << stress_tally_text(stress_tally(results)) << ". Rows in the `stock` world are stock Bullet's verdicts, "
    << "shown for comparison.\n\n";
  s << "| case | world | precision | dt x iterations | steps | result | measured | wall s |\n"
    << "|---|---|---|---|---|---|---|---|\n";
  for (const StressResult& r : results) {
    std::string world = world_kind_name(r.c.world);
    if (r.c.ccd) world += " + CCD";
    if (r.c.world == WorldKind::Stock) world += " (comparison)";
    std::string dt = r.c.dt > 0 ? "1/" + fmt("%.0f", 1.0 / r.c.dt) : "?";
    if (r.c.substeps > 1) dt += " (" + std::to_string(r.c.substeps) + " substeps)";
    s << "| " << r.c.name << " | " << world << " | " << r.precision << " | " << dt << " x " << r.c.iterations
      << " | " << r.steps_run << " | "
      << (r.status == "pass" ? "pass" : "**" + r.status + "**") << " | " << cell(r.measured) << " | "
      << fmt("%.2f", r.wall_seconds) << " |\n";
  }
  return s.str();
}

}  // namespace soda
