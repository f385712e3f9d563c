// Analytic scenes against closed forms (accuracy_analytic.h). Every
// tolerance below is documented, with its reason, in docs/accuracy.md.
// A scene is recorded once per run (every body's raw state after every
// step); its checks read the recording, so one world and a partitioned run
// go through exactly the same checks, and the recordings' per-step state
// hashes give the decomposition error.
#include "soda/bench/accuracy_analytic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "soda/bench/accuracy.h"
#include "soda/grid/partition.h"
#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"

#include <btBulletDynamicsCommon.h>

namespace soda {
namespace {

// What the checks read: the raw state of every body (statics included, by
// id) after every step, index 0 before the first, and its state hash.
struct Recording {
  std::vector<std::vector<BodyState>> states;
  std::vector<std::uint64_t> hashes;
};

template <class W>
Recording record(W& world, int steps) {
  Recording r;
  auto keep = [&] {
    r.states.push_back(world.body_states());
    r.hashes.push_back(state_hash(r.states.back()));
  };
  keep();
  for (int k = 0; k < steps; ++k) {
    world.step();
    keep();
  }
  return r;
}

Recording record_one_world(const Scene& scene, WorldKind kind, int steps) {
  if (kind == WorldKind::Stock) {
    StockWorld w(scene);
    return record(w, steps);
  }
  CanonicalWorld w(scene);
  return record(w, steps);
}

// States of the dynamic bodies after every step (index 0: before the first).
std::vector<std::vector<BodySample>> samples(const Scene& scene, const Recording& r) {
  std::vector<std::vector<BodySample>> out;
  out.reserve(r.states.size());
  for (const auto& s : r.states) out.push_back(to_samples(scene, s));
  return out;
}

Vec3 pos(const BodySample& s) { return {s.position[0], s.position[1], s.position[2]}; }
Vec3 vel(const BodySample& s) { return {s.linear_velocity[0], s.linear_velocity[1], s.linear_velocity[2]}; }
Vec3 ang(const BodySample& s) { return {s.angular_velocity[0], s.angular_velocity[1], s.angular_velocity[2]}; }

AnalyticCheck check(std::string scene, std::string quantity, double measured, double tolerance, std::string unit,
                    std::string reason) {
  AnalyticCheck c;
  c.scene = std::move(scene);
  c.quantity = std::move(quantity);
  c.measured = measured;
  c.tolerance = tolerance;
  c.unit = std::move(unit);
  c.reason = std::move(reason);
  c.pass = std::isfinite(measured) && measured <= tolerance;
  return c;
}

// Free fall: Bullet's semi-implicit Euler, v_{k+1} = v_k + g dt,
// x_{k+1} = x_k + v_{k+1} dt, recomputed here in btScalar, operation for
// operation; and the continuous parabola, which the discrete one trails by
// g dt^2 n / 2.
void free_fall(const Scene& scene, const Recording& run, std::vector<AnalyticCheck>& out) {
  const int n = static_cast<int>(run.states.size()) - 1;  // 180 steps, 3 s, free flight throughout
  const auto states = samples(scene, run);
  const btScalar g = btScalar(scene.settings.gravity.y());
  const btScalar dt = btScalar(scene.settings.dt);
  btScalar v = 0, y = btScalar(scene.bodies[1].position.y());
  double worst_y = 0, worst_v = 0, worst_parabola = 0, max_y = 0, max_v = 0;
  const double eps = scalar_epsilon();
  for (int k = 1; k <= n; ++k) {
    v = v + g * dt;
    y = y + v * dt;
    const BodySample& s = states[static_cast<std::size_t>(k)][0];
    worst_y = std::max(worst_y, std::abs(s.position[1] - static_cast<double>(y)));
    worst_v = std::max(worst_v, std::abs(s.linear_velocity[1] - static_cast<double>(v)));
    max_y = std::max(max_y, std::abs(s.position[1]));
    max_v = std::max(max_v, std::abs(s.linear_velocity[1]));
    // Continuous parabola minus the discrete offset, in double.
    const double t = k * scene.settings.dt, gd = scene.settings.gravity.y();
    const double parabola = 100.0 + 0.5 * gd * t * t;
    const double offset = -0.5 * gd * scene.settings.dt * scene.settings.dt * k;  // g dt^2 k / 2 (> 0)
    worst_parabola = std::max(worst_parabola, std::abs((parabola - s.position[1]) - offset));
  }
  // Same operations in the same precision: bit-identical is expected; allow
  // 4 ulp of the largest magnitude for an equivalent but reordered sum.
  out.push_back(check("free-fall", "|y - y_semi-implicit| max over 180 steps", worst_y, 4 * eps * max_y, "m",
                      "same operation sequence in btScalar: equal up to rounding (4 ulp of |y|max)"));
  out.push_back(check("free-fall", "|v - v_semi-implicit| max over 180 steps", worst_v, 4 * eps * max_v, "m/s",
                      "same operation sequence in btScalar: equal up to rounding (4 ulp of |v|max)"));
  // Rounding bound of n steps: position sums add <= 2 eps |y|max each,
  // velocity sums add <= eps |v|max each, carried into y over the remaining steps.
  const double bound = eps * (2.0 * n * max_y + 0.5 * n * n * max_v * scene.settings.dt) + 1e-12;
  out.push_back(check("free-fall", "|(y_parabola - y) - g dt^2 n/2| max", worst_parabola, bound, "m",
                      "exact identity y_n = y0 - g dt^2 n(n+1)/2; only accumulated rounding remains "
                      "(eps (2 n |y|max + n^2 |v|max dt / 2))"));
}

// Incline: a = g (sin t - mu cos t) along the slope; the semi-implicit
// discrete form s_n = a dt^2 n (n+1) / 2.
void incline(const Scene& scene, const Recording& run, std::vector<AnalyticCheck>& out) {
  const int n = static_cast<int>(run.states.size()) - 1;  // 600 steps, 10 s: 117.8 m of the 125 m slope
  const auto states = samples(scene, run);
  const double theta = std::numbers::pi / 6, mu = 0.3, g = -scene.settings.gravity.y(), dt = scene.settings.dt;
  const double a = g * (std::sin(theta) - mu * std::cos(theta));
  const Vec3 down(std::cos(theta), -std::sin(theta), 0.0), normal(std::sin(theta), std::cos(theta), 0.0);
  const Vec3 x0 = pos(states[0][0]);
  double worst_rel = 0, worst_normal = 0, worst_v = 0;
  for (int k = 1; k <= n; ++k) {
    const BodySample& s = states[static_cast<std::size_t>(k)][0];
    const double along = (pos(s) - x0).dot(down);
    const double expected = a * dt * dt * k * (k + 1) / 2.0;
    worst_normal = std::max(worst_normal, std::abs((pos(s) - x0).dot(normal)));
    // The first steps are a landing transient (the zero-gap contact may not be
    // seen in step 1): relative errors of small distances say nothing.
    if (k * dt < 1.0) continue;
    worst_rel = std::max(worst_rel, std::abs(along - expected) / expected);
    worst_v = std::max(worst_v, std::abs(vel(s).dot(down) - a * dt * k) / (a * dt * k));
  }
  out.push_back(check("incline", "|s - a dt^2 n(n+1)/2| / s, max for t in [1, 10] s", worst_rel, 0.01, "relative",
                      "Coulomb friction by sequential impulses: 4 contact points each clamped at mu x its own "
                      "normal impulse, 10 iterations; 1 % of the distance"));
  out.push_back(check("incline", "|v - a t| / (a t), max for t in [1, 10] s", worst_v, 0.01, "relative",
                      "as the position: 1 %"));
  out.push_back(check("incline", "|displacement along the normal|, max", worst_normal, 0.01, "m",
                      "resting penetration plus rounding of a box 70 m from the origin: 1 cm (1 % of the edge)"));
}

// Resting stack: nothing should move. It settles into its resting contacts
// (sub-millimetre jitter while the solver converges), falls asleep, and from
// then on must not move at all.
void resting_stack(const Scene& scene, const Recording& run, std::vector<AnalyticCheck>& out) {
  const int n = static_cast<int>(run.states.size()) - 1;  // 600 steps
  const auto states = samples(scene, run);
  double worst = 0, drift_asleep = 0;
  int asleep_at = -1;
  // Dynamic bodies asleep, from the raw activation states (Bullet also marks
  // static bodies asleep).
  auto sleeping = [&](const std::vector<BodyState>& raw) {
    std::size_t asleep = 0;
    for (const BodyState& b : raw)
      if (b.id != 0 && b.activation_state == ISLAND_SLEEPING) ++asleep;
    return asleep;
  };
  const std::vector<BodySample>& initial = states[0];
  for (int k = 1; k <= n; ++k) {
    const std::vector<BodySample>& now = states[static_cast<std::size_t>(k)];
    for (std::size_t i = 0; i < now.size(); ++i) worst = std::max(worst, (pos(now[i]) - pos(initial[i])).norm());
    if (asleep_at < 0 && sleeping(run.states[static_cast<std::size_t>(k)]) == now.size()) asleep_at = k;
    if (asleep_at >= 0) {
      const std::vector<BodySample>& at_sleep = states[static_cast<std::size_t>(asleep_at)];
      for (std::size_t i = 0; i < now.size(); ++i)
        drift_asleep = std::max(drift_asleep, (pos(now[i]) - pos(at_sleep[i])).norm());
    }
  }
  out.push_back(check("resting-stack", "max displacement of any box over 600 steps", worst, 0.005, "m",
                      "settling: sequential impulses on 4 points per contact jitter the boxes by 1-2 mm before "
                      "they sleep (observed); bound 5 mm = 0.5 % of the edge"));
  out.push_back(check("resting-stack", "steps until every box is asleep", asleep_at < 0 ? 1e9 : asleep_at, 300,
                      "steps", "Bullet sleeps a body after 2 s (120 steps) below its thresholds; 300 steps (5 s) "
                      "allows for settling first"));
  out.push_back(check("resting-stack", "drift once asleep (to step 600)", asleep_at < 0 ? 1e9 : drift_asleep, 0.0,
                      "m", "sleeping bodies are not integrated: exactly zero"));
}

// Rolling without slipping: x(t) = -10 + 2 t, v = omega r.
void rolling_sphere(const Scene& scene, const Recording& run, std::vector<AnalyticCheck>& out) {
  const int n = static_cast<int>(run.states.size()) - 1;  // 600 steps, 10 s
  const auto states = samples(scene, run);
  const double r = 0.5, v0 = 2.0, dt = scene.settings.dt;
  double worst_x = 0, worst_slip = 0;
  for (int k = 0; k <= n; ++k) {
    const BodySample& s = states[static_cast<std::size_t>(k)][0];
    worst_x = std::max(worst_x, std::abs(s.position[0] - (-10.0 + v0 * k * dt)));
    // Contact-point velocity v + w x (-r y): its x component is v_x + w_z r.
    worst_slip = std::max(worst_slip, std::abs(vel(s).x() + ang(s).z() * r));
  }
  const double eps = scalar_epsilon();
  out.push_back(check("rolling-sphere", "|x - (-10 + 2 t)| max over 10 s", worst_x, 2.0 * n * eps * 10.0, "m",
                      "no rolling resistance in Bullet and the contact point at rest: no impulse, so x is exact "
                      "up to the rounding of n position sums, 2 n eps |x|max"));
  out.push_back(check("rolling-sphere", "|v_x + w_z r| (slip speed) max", worst_slip, 100.0 * eps * v0, "m/s",
                      "no slip is kept to rounding: 100 ulp of v"));
}

// The scenes in order, with the steps each is run for.
struct AnalyticScene {
  const char* name;
  int steps;  // 0: the scene's own (free-fall: 180)
  void (*checks)(const Scene&, const Recording&, std::vector<AnalyticCheck>&);
};
constexpr AnalyticScene kScenes[] = {
    {"free-fall", 0, free_fall},
    {"incline", 600, incline},
    {"resting-stack", 600, resting_stack},
    {"rolling-sphere", 600, rolling_sphere},
};

GridOptions grid_options(double cell_size, const Vec3& origin, const CellBox& box) {
  GridOptions g;
  g.cell_size = cell_size;
  g.origin = origin;
  g.box = box;
  return g;
}

// Distinct owners of the dynamic bodies' home cells (grid cell of the origin
// as Bullet holds it: the partitioned step's rule, docs/partitioned-step.md).
void add_owners(const Scene& scene, const TerritoryMap& map, const std::vector<BodyState>& states,
                std::set<WorldId>& owners) {
  for (const BodyState& b : states) {
    const auto body =
        std::find_if(scene.bodies.begin(), scene.bodies.end(), [&](const Body& x) { return x.id == b.id; });
    if (body == scene.bodies.end() || body->is_static) continue;
    owners.insert(map.owner_of(Vec3(static_cast<double>(b.origin[0]), static_cast<double>(b.origin[1]),
                                    static_cast<double>(b.origin[2]))));
  }
}

// Every lower bound of the partition, with the value reached; false if one
// is not reached.
bool describe_mechanism(const AnalyticPartition& p, const AnalyticRun& r, std::string& text) {
  bool fired = true;
  auto bound = [&](const char* name, std::uint64_t reached, std::uint64_t minimum) {
    if (minimum == 0) return;
    if (!text.empty()) text += ", ";
    text += std::string(name) + " " + std::to_string(reached) + " >= " + std::to_string(minimum);
    if (reached < minimum) {
      fired = false;
      text += " NOT REACHED";
    }
  };
  auto u = [](int v) { return static_cast<std::uint64_t>(v); };
  bound("owners at start", u(r.owners_at_start), u(p.min_owners_at_start));
  bound("owners visited", u(r.owners_visited), u(p.min_owners_visited));
  bound("migrations", r.total.migrations_out, p.min_migrations);
  bound("ghosts sent", r.total.ghosts_sent, p.min_ghosts);
  bound("border islands", r.total.islands_solved, p.min_border_islands);
  return fired;
}

// One scene on its partition, compared with the one-territory recording
// `one` step by step.
AnalyticRun run_partitioned(const AnalyticScene& as, const Scene& scene, const AnalyticPartition& p,
                            const Recording& one) {
  const int steps = static_cast<int>(one.states.size()) - 1;
  const TerritoryMap map = make_partition(p.spec, scene, p.territories, p.grid);
  PartitionedWorld world(scene, map,
                         PartitionedOptions{.schedule = Schedule::Sequential, .serialise = true, .runtime = {.validate = true}});
  Recording rec;
  std::set<WorldId> at_start, visited;
  auto keep = [&] {
    rec.states.push_back(world.body_states());
    rec.hashes.push_back(state_hash(rec.states.back()));
    add_owners(scene, map, rec.states.back(), visited);
  };
  keep();
  add_owners(scene, map, rec.states.front(), at_start);
  for (int k = 0; k < steps; ++k) {
    world.step(1);
    keep();
  }

  AnalyticRun r;
  r.scene = as.name;
  r.territories = p.territories;
  r.partition = p.spec;
  r.borders = p.borders;
  r.steps = steps;
  r.state_hash = rec.hashes.back();
  r.one_territory_hash = one.hashes.back();
  for (int k = 0; k <= steps; ++k)
    if (rec.hashes[static_cast<std::size_t>(k)] != one.hashes[static_cast<std::size_t>(k)]) {
      ++r.divergent_steps;
      if (r.first_divergent_step < 0) r.first_divergent_step = k;
    }
  r.owners_at_start = static_cast<int>(at_start.size());
  r.owners_visited = static_cast<int>(visited.size());
  r.total = total_metrics(world.metrics());
  r.mechanism_fired = describe_mechanism(p, r, r.mechanism);

  as.checks(scene, rec, r.checks);
  r.checks.push_back(check(as.name, "decomposition error: steps with hash != 1 territory's",
                           r.divergent_steps, 0, "steps",
                           "the partitioned step is bit-identical to one world (docs/partitioned-step.md): the "
                           "state hash of every step equals the one-territory run's"));
  for (AnalyticCheck& c : r.checks) {
    c.territories = p.territories;
    c.partition = p.spec;
  }
  return r;
}

}  // namespace

double scalar_epsilon() { return static_cast<double>(std::numeric_limits<btScalar>::epsilon()); }

std::vector<AnalyticPartition> analytic_partitions() {
  std::vector<AnalyticPartition> out;
  {
    // 10 m cells, box y in cells 6..10 (y in [60, 110)): 4 slabs along y cut
    // at cells 7, 8, 9.
    AnalyticPartition p{"free-fall", "grid:1x4x1", 4,
                        grid_options(10.0, Vec3::Zero(), CellBox{{-1, 6, -1}, {0, 10, 0}}),
                        "horizontal borders at y = 90, 80, 70 m: the sphere, falling from y = 100 to 55.6 m, crosses "
                        "them at steps 86, 121 and 148"};
    p.min_owners_visited = 4;
    p.min_migrations = 3;
    p.min_ghosts = 1;
    out.push_back(p);
  }
  {
    // 2 m cells whose origin is the box's centre line at x = 40 m; box 4 x 4
    // x 2 cells around it: every axis cut at cell 0 (the origin).
    const double y_at_40 = 70.0 - 40.0 * std::tan(std::numbers::pi / 6);
    AnalyticPartition p{"incline", "grid:2x2x2", 8,
                        grid_options(2.0, Vec3(20.0, y_at_40, 0.0), CellBox{{-2, -2, -1}, {1, 1, 0}}),
                        "borders at x = 20 m, y = 46.91 m (the box's height at x = 40 m) and z = 0: the box slides "
                        "along z = 0 (straddling it throughout), crosses x = 20 m where four territories meet "
                        "(t = 4.4 s), then y = 46.91 m (t = 6.3 s)"};
    p.min_owners_visited = 3;
    p.min_migrations = 2;
    p.min_ghosts = 1;
    out.push_back(p);
  }
  {
    // 2 m cells at origin (0, 1, 0), box 2 x 3 x 2 cells: cut at cell 0 on
    // every axis.
    AnalyticPartition p{"resting-stack", "grid:2x2x2", 8,
                        grid_options(2.0, Vec3(0.0, 1.0, 0.0), CellBox{{-1, -1, -1}, {0, 1, 0}}),
                        "borders at x = 0, z = 0 (the stack stands on the corner of four territories) and y = 1 m "
                        "(between the bottom box and the two above it: bodies on both sides)"};
    p.min_owners_at_start = 2;
    p.min_ghosts = 1;
    p.min_border_islands = 1;
    out.push_back(p);
  }
  {
    // 1 m cells at the origin, box x in cells -10..9, z in -1..0: 4 slabs
    // along x cut at -5, 0, 5, 2 along z cut at 0.
    AnalyticPartition p{"rolling-sphere", "grid:4x1x2", 8,
                        grid_options(1.0, Vec3::Zero(), CellBox{{-10, 0, -1}, {9, 0, 0}}),
                        "borders at x = -5, 0, 5 m and z = 0: the sphere rolls along z = 0 (straddling it "
                        "throughout) from x = -10 to 10 m, crossing each x border where four territories meet "
                        "(t = 2.5, 5, 7.5 s)"};
    p.min_owners_visited = 4;
    p.min_migrations = 3;
    p.min_ghosts = 1;
    out.push_back(p);
  }
  return out;
}

std::vector<AnalyticRun> run_analytic(WorldKind world, bool partitioned) {
  const std::vector<AnalyticPartition> partitions = analytic_partitions();
  std::vector<AnalyticRun> one_world, split;
  for (const AnalyticScene& as : kScenes) {
    const Scene scene = make_scene(as.name, {});
    const int steps = as.steps > 0 ? as.steps : scene.settings.steps;
    const Recording one = record_one_world(scene, world, steps);
    AnalyticRun r;
    r.scene = as.name;
    r.world = world;
    r.steps = steps;
    r.state_hash = one.hashes.back();
    r.one_territory_hash = one.hashes.back();
    as.checks(scene, one, r.checks);
    one_world.push_back(std::move(r));
    if (!partitioned) continue;
    // Partitioned runs are compared with the one-territory canonical run.
    const Recording canonical =
        world == WorldKind::Canonical ? Recording{} : record_one_world(scene, WorldKind::Canonical, steps);
    const Recording& reference = world == WorldKind::Canonical ? one : canonical;
    for (const AnalyticPartition& p : partitions)
      if (p.scene == as.name) split.push_back(run_partitioned(as, scene, p, reference));
  }
  one_world.insert(one_world.end(), std::make_move_iterator(split.begin()), std::make_move_iterator(split.end()));
  return one_world;
}

std::vector<AnalyticCheck> run_analytic_checks(WorldKind world) {
  std::vector<AnalyticCheck> out;
  for (AnalyticRun& r : run_analytic(world, false))
    out.insert(out.end(), std::make_move_iterator(r.checks.begin()), std::make_move_iterator(r.checks.end()));
  return out;
}

}  // namespace soda
