// The joint cases of the stress suite (stress_joints.h). Pass criteria and
// why each bound is what it is: docs/stress.md, "Joint cases".
#include "soda/bench/stress_joints.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>

#include <btBulletDynamicsCommon.h>

#include "soda/bench/accuracy.h"
#include "soda/bench/solver_variant.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/solver_pool.h"
#include "soda/worlds/stock_world.h"
#include "soda/worlds/watchdog.h"

namespace soda {
namespace {

// The bounds (docs/stress.md, "Joint cases", says why).
constexpr double kChainLink = 0.5;            // m: hanging-chain's and heavy-chain's link length, pivot to pivot
constexpr double kChainStretch = 0.05;        // largest pivot gap / link length, any joint, any step
constexpr int kStockChainSubsteps = 4;        // stock Bullet's chains: whole-world substeps (at 1 > 100 %)
constexpr double kRagdollSpeedFactor = 2.0;   // x the free-fall speed from the highest start
constexpr double kMotorSpeedTolerance = 0.01; // relative, of the free arm's speed about the axis
constexpr double kMotorSettle = 0.5;          // s: the motors' time to reach their target
constexpr double kLimitTolerance = 0.02;      // rad: the limited arm's angle from its upper limit
constexpr double kLimitReached = 2.5;         // s: by when (the motor needs pi/2 s at 1 rad/s)

std::string joint_fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Every body's pose at the latest step: dynamic bodies from the step's
// samples, statics from the scene.
class Poses {
 public:
  explicit Poses(const Scene& scene) {
    for (const Body& b : scene.bodies) poses_[b.id] = {b.position, b.orientation.normalized()};
  }
  void update(const std::vector<BodySample>& now) {
    for (const BodySample& s : now)
      poses_[s.id] = {Vec3(s.position[0], s.position[1], s.position[2]),
                      Quat(s.orientation[3], s.orientation[0], s.orientation[1], s.orientation[2])};
  }
  const Pose& at(BodyId id) const { return poses_.at(id); }
  // The distance between a joint's two pivots (its frames' origins) in the world.
  double gap(const Joint& j) const {
    const Pose& a = at(j.body_a);
    const Pose& b = at(j.body_b);
    return ((a.position + a.orientation * j.frame_a.position) - (b.position + b.orientation * j.frame_b.position)).norm();
  }
  // A hinge's angle as Bullet's btHingeConstraint::getHingeAngle gives it
  // (rad, in (-pi, pi]): the rotation of joint frame b about frame a's z
  // axis, clockwise positive.
  double hinge_angle(const Joint& j) const {
    const Quat fa = at(j.body_a).orientation * j.frame_a.orientation;
    const Quat fb = at(j.body_b).orientation * j.frame_b.orientation;
    const Quat rel = (fa.conjugate() * fb).normalized();
    return -2.0 * std::atan2(rel.z(), rel.w());
  }

 private:
  std::map<BodyId, Pose> poses_;
};

// One run: after every step the visitor sees the dynamic bodies (id order).
// A non-finite state, or in the canonical world a watchdog finding (default
// limits), stops the run at that step.
struct JointRun {
  int steps_run = 0;
  double wall_seconds = 0;
  std::string stopped;  // why the run stopped early; empty when it ran every step
  std::size_t sleeping = 0;
  std::uint64_t hash = 0;
};
using StepVisitor = std::function<void(int step, const std::vector<BodySample>& now)>;

template <class W>
JointRun step_and_watch(W& world, const Scene& scene, int steps, const StepVisitor& visit) {
  JointRun run;
  for (int k = 1; k <= steps; ++k) {
    const std::int64_t a = wall_ns();
    world.step();
    run.wall_seconds += static_cast<double>(wall_ns() - a) * 1e-9;
    run.steps_run = k;
    const std::vector<BodyState> raw = world.body_states();
    if (!std::all_of(raw.begin(), raw.end(), is_finite)) {
      run.stopped = "non-finite state at step " + std::to_string(k) + ": stopped";
      break;
    }
    if constexpr (requires { world.watchdog_findings(WatchdogLimits{}); }) {
      const WatchdogLimits limits;
      const std::vector<WatchdogFinding> findings = world.watchdog_findings(limits);
      if (!findings.empty()) {
        run.stopped = "watchdog: step " + std::to_string(k) + ": " + describe(findings.front(), limits) + ": stopped";
        break;
      }
    }
    visit(k, to_samples(scene, raw));
  }
  run.sleeping = world.sleeping_count();
  run.hash = world.state_hash();
  return run;
}

JointRun run_joint_world(const Scene& scene, const StressCase& c, const StepVisitor& visit) {
  std::unique_ptr<btConstraintSolver> variant_solver;  // outlives the world
  if (c.world == WorldKind::Stock) {
    StockWorld w(scene);
    apply_solver_variant(w.bullet(), c.variant, variant_solver);
    return step_and_watch(w, scene, c.steps, visit);
  }
  CanonicalWorld w(scene);
  if (c.solver_threads > 1) w.set_solver_pool(std::make_shared<SolverPool>(c.solver_threads));
  apply_solver_variant(w.bullet(), c.variant, variant_solver);
  return step_and_watch(w, scene, c.steps, visit);
}

void joint_verdict(StressResult& r, const JointRun& run, bool pass, double metric, double threshold,
                   std::string measured) {
  r.steps_run = run.steps_run;
  r.wall_seconds = run.wall_seconds;
  r.sleeping = run.sleeping;
  r.state_hash = hash_hex(run.hash);
  r.threshold = threshold;
  if (!run.stopped.empty()) {
    r.status = "FAIL";
    r.metric = std::numeric_limits<double>::quiet_NaN();
    r.measured = run.stopped;
    return;
  }
  r.status = pass ? "pass" : "FAIL";
  r.metric = metric;
  r.measured = std::move(measured);
}

// The bound of a case: its own, or the case's override (tests).
double bound_of(const StressCase& c, double own) { return c.bound > 0 ? c.bound : own; }

// Chains (pendulums, heavy-chain): the largest gap between a joint's two
// pivots over the run, relative to the link length.
void run_chain(StressResult& r, const Scene& scene, const StressCase& c) {
  Poses poses(scene);
  const EnergyTable energy(scene);
  double worst = 0, worst_end = 0, e0 = 0, e_max = 0;
  int worst_step = 0;
  JointId worst_joint = 0;
  const JointRun run = run_joint_world(scene, c, [&](int k, const std::vector<BodySample>& now) {
    poses.update(now);
    double step_worst = 0;
    for (const Joint& j : scene.joints) {
      const double g = poses.gap(j);
      step_worst = std::max(step_worst, g);
      if (g > worst) worst = g, worst_step = k, worst_joint = j.id;
    }
    worst_end = step_worst;
    const double e = energy.energy(now);
    if (k == 1) e0 = e;
    e_max = std::max(e_max, e);
  });
  const double stretch = worst / kChainLink, bound = bound_of(c, kChainStretch);
  const double dt = scene.settings.dt;
  joint_verdict(r, run, stretch <= bound, stretch, bound,
                "largest pivot gap " + joint_fmt("%.4g", worst) + " m = " + joint_fmt("%.3g", 100 * stretch) +
                    " % of the link (joint " + std::to_string(worst_joint) + ", t " +
                    joint_fmt("%.2f", worst_step * dt) + " s; limit " + joint_fmt("%.3g", 100 * bound) +
                    " %); at the end " + joint_fmt("%.3g", 100 * worst_end / kChainLink) +
                    " %; for information: E_max - E(step 1) " + joint_fmt("%.3g", e_max - e0) + " J");
}

// The scene's dynamic bodies as samples at their start (id order).
std::vector<BodySample> start_samples(const Scene& scene) {
  std::vector<BodySample> out;
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    BodySample s;
    s.id = b.id;
    const Quat q = b.orientation.normalized();
    const double quat[4] = {q.x(), q.y(), q.z(), q.w()};
    for (int i = 0; i < 3; ++i) {
      s.position[i] = b.position[i];
      s.linear_velocity[i] = b.linear_velocity[i];
      s.angular_velocity[i] = b.angular_velocity[i];
    }
    std::copy(quat, quat + 4, s.orientation);
    out.push_back(s);
  }
  std::sort(out.begin(), out.end(), [](const BodySample& a, const BodySample& b) { return a.id < b.id; });
  return out;
}

// How far below the ground's top face a body's centre may go before the body
// is wholly under it: a capsule's or sphere's radius, else the smallest half
// extent.
double sink_limit(const Body& b) {
  if (b.shape.kind == ShapeKind::Capsule || b.shape.kind == ShapeKind::Sphere) return b.shape.radius;
  const Vec3 h = b.shape.local_half_extents();
  return h.minCoeff();
}

// The ragdoll pile: nothing explodes.
void run_ragdoll_pile(StressResult& r, const Scene& scene, const StressCase& c) {
  Poses poses(scene);
  const EnergyTable energy(scene);
  const Body& ground = scene.bodies.front();  // id 0, top face at y = 0: its half extents are the arena
  const double half = ground.shape.half_extents.x();
  double top = 0;
  std::map<BodyId, double> floor;  // the lowest centre y of each dynamic body still in the arena
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    top = std::max(top, b.position.y());
    floor[b.id] = -sink_limit(b);
  }
  const double free_fall = std::sqrt(2.0 * scene.settings.gravity.norm() * top);
  const double speed_bound = bound_of(c, kRagdollSpeedFactor * free_fall);
  const double e0 = energy.energy(start_samples(scene));
  double max_speed = 0, gap = 0, e_max = e0, e_end = e0, reach = 0, lowest = std::numeric_limits<double>::infinity();
  std::size_t outside = 0;
  const JointRun run = run_joint_world(scene, c, [&](int, const std::vector<BodySample>& now) {
    poses.update(now);
    for (const BodySample& s : now) {
      max_speed = std::max(max_speed, std::hypot(s.linear_velocity[0], s.linear_velocity[1], s.linear_velocity[2]));
      reach = std::max({reach, std::abs(s.position[0]), std::abs(s.position[2])});
      lowest = std::min(lowest, s.position[1]);
      if (std::abs(s.position[0]) > half || std::abs(s.position[2]) > half || s.position[1] < floor.at(s.id)) ++outside;
    }
    for (const Joint& j : scene.joints) gap = std::max(gap, poses.gap(j));
    e_end = energy.energy(now);
    e_max = std::max(e_max, e_end);
  });
  const bool pass = outside == 0 && max_speed <= speed_bound && e_max <= e0;
  joint_verdict(r, run, pass, max_speed, speed_bound,
                "fastest body " + joint_fmt("%.3g", max_speed) + " m/s (limit " + joint_fmt("%.3g", speed_bound) +
                    " m/s: " + joint_fmt("%.3g", speed_bound / free_fall) + " x the free fall from " +
                    joint_fmt("%.3g", top) + " m); " + std::to_string(outside) +
                    " body-steps outside the arena (largest |x|,|z| " + joint_fmt("%.3g", reach) + " m of " +
                    joint_fmt("%.3g", half) + ", lowest centre " + joint_fmt("%.3g", lowest) +
                    " m); E_max - E_0 = " + joint_fmt("%.3g", e_max - e0) + " J (E_0 " + joint_fmt("%.4g", e0) +
                    " J, at the end " + joint_fmt("%.4g", e_end) + " J); for information: largest pivot gap " +
                    joint_fmt("%.3g", gap) + " m; " + std::to_string(run.sleeping) + "/" +
                    std::to_string(scene.dynamic_count()) + " asleep");
}

// Motorised hinges (motor-hinge): joint 0 drives a free arm at its target
// speed, joint 1 turns a limited arm to the limit its motor drives towards
// and holds it there.
void run_motor_hinge(StressResult& r, const Scene& scene, const StressCase& c) {
  Poses poses(scene);
  const Joint& free_hinge = scene.joints.at(0);
  const Joint& limited = scene.joints.at(1);
  const double goal = limited.motor_velocity > 0 ? limited.upper : limited.lower;
  const double target = free_hinge.motor_velocity, dt = scene.settings.dt;
  const int settle = static_cast<int>(std::lround(kMotorSettle / dt));
  const int reached_by = static_cast<int>(std::lround(kLimitReached / dt));
  const double tolerance = bound_of(c, kMotorSpeedTolerance);
  double worst_speed = 0, turned = 0, previous = 0, worst_limit = 0, end_angle = 0, angle_at_settle = 0;
  int first_at_limit = -1;
  const JointRun run = run_joint_world(scene, c, [&](int k, const std::vector<BodySample>& now) {
    poses.update(now);
    // The free arm's speed about the hinge axis (frame a's z in the world;
    // the post is static), with the hinge angle's sign: clockwise positive.
    const Vec3 axis = poses.at(free_hinge.body_a).orientation * (free_hinge.frame_a.orientation * Vec3::UnitZ());
    Vec3 wb = Vec3::Zero();
    for (const BodySample& s : now)
      if (s.id == free_hinge.body_b) wb = Vec3(s.angular_velocity[0], s.angular_velocity[1], s.angular_velocity[2]);
    const double speed = -wb.dot(axis);
    const double angle = poses.hinge_angle(free_hinge);
    double step = angle - previous;  // unwrapped: the arm turns less than pi a step
    if (step > std::numbers::pi) step -= 2 * std::numbers::pi;
    if (step < -std::numbers::pi) step += 2 * std::numbers::pi;
    turned += step;
    previous = angle;
    if (k == settle) angle_at_settle = turned;
    if (k > settle) worst_speed = std::max(worst_speed, std::abs(speed - target) / std::abs(target));
    end_angle = poses.hinge_angle(limited);
    const double off = std::abs(end_angle - goal);
    if (first_at_limit < 0 && off <= kLimitTolerance) first_at_limit = k;
    if (k >= reached_by) worst_limit = std::max(worst_limit, off);
  });
  const double span = (run.steps_run - settle) * dt;
  const double mean_speed = span > 0 ? (turned - angle_at_settle) / span : 0.0;
  const bool pass = run.steps_run > reached_by && worst_speed <= tolerance && first_at_limit > 0 &&
                    first_at_limit <= reached_by && worst_limit <= kLimitTolerance;
  joint_verdict(r, run, pass, worst_speed, tolerance,
                "free arm: speed about the axis at most " + joint_fmt("%.3g", 100 * worst_speed) +
                    " % from the target " + joint_fmt("%.3g", target) + " rad/s after " +
                    joint_fmt("%.2g", kMotorSettle) + " s (limit " + joint_fmt("%.3g", 100 * tolerance) +
                    " %), mean " + joint_fmt("%.5g", mean_speed) + " rad/s, turned " + joint_fmt("%.4g", turned) +
                    " rad; limited arm: within " + joint_fmt("%.2g", kLimitTolerance) + " rad of its limit " +
                    joint_fmt("%.4g", goal) + " rad at " +
                    (first_at_limit > 0 ? joint_fmt("%.2f s", first_at_limit * dt) : std::string("never")) +
                    ", then at most " + joint_fmt("%.3g", worst_limit) + " rad off after " +
                    joint_fmt("%.2g", kLimitReached) + " s, ends at " + joint_fmt("%.4g", end_angle) + " rad");
}

}  // namespace

void add_joint_stress_cases(std::vector<StressCase>& suite, bool quick) {
  auto both = [&](StressCase c) {
    suite.push_back(c);
    c.name += "-stock";
    c.world = WorldKind::Stock;
    suite.push_back(std::move(c));
  };
  const int steps = quick ? 120 : 600;
  const std::string stretch = "at most " + joint_fmt("%.0f", 100 * kChainStretch) + " % of the link length";
  // SODA at its defaults (an island of a tall or heavy-on-light joint chain
  // is solved in substeps: island_solver_settings.h); stock Bullet, which has
  // no such rule, given kStockChainSubsteps substeps of the whole world.
  auto chain = [&](StressCase c) {
    suite.push_back(c);
    c.name += "-stock";
    c.world = WorldKind::Stock;
    c.substeps = kStockChainSubsteps;
    suite.push_back(std::move(c));
  };
  chain({"hanging-chain-100", "hanging-chain", "hanging-chain", 100, steps, WorldKind::Canonical, false, false,
         "a chain of 100 point-to-point links (0.5 m, 1 kg) hanging from a static anchor, its lowest link pushed "
         "sideways at 2 m/s, " + std::to_string(steps / 60) + " s in steps of 1/60 s (stock Bullet: of 4 substeps): the gap "
         "between a joint's two pivots stays " + stretch + " at every joint and step"});
  const int pile = quick ? 16 : 64;
  both({"ragdoll-pile-" + std::to_string(pile), "ragdoll-pile", "ragdolls", pile, steps, WorldKind::Canonical,
        false, false,
        std::to_string(pile) + " ragdolls (11 capsules, 10 joints each) falling into a pile, " +
            std::to_string(steps / 60) +
            " s: no non-finite state, no body faster than 2 x the free fall from the highest start, no body leaves "
            "the arena (centre over the ground, and not wholly below its top face: centre y >= -radius), no energy "
            "gain (E never above E_0)"});
  chain({"heavy-chain-1:100", "heavy-chain", "heavy-chain", 100, steps, WorldKind::Canonical, false, false,
         "a 100 kg box hanging on a chain of ten 1 kg links (0.5 m), pushed sideways at 1 m/s, " +
             std::to_string(steps / 60) + " s in steps of 1/60 s (stock Bullet: of 4 substeps): the gap between a joint's two "
             "pivots stays " + stretch + " at every joint and step"});
  both({"motor-hinge", "motor-hinge", "motor-hinge", 2, quick ? 180 : 600, WorldKind::Canonical, false, false,
        "hinge motors: after 0.5 s the free arm turns at its target 2 rad/s within 1 % at every step; the "
        "limited arm, lifted at 1 rad/s, is within 0.02 rad of its limit (the vertical) by 2.5 s and stays there"});
}

bool is_joint_stress_group(const std::string& group) {
  return group == "hanging-chain" || group == "ragdoll-pile" || group == "heavy-chain" || group == "motor-hinge";
}

void run_joint_stress_case(StressResult& r, const Scene& scene, const StressCase& c) {
  if (c.group == "ragdoll-pile") return run_ragdoll_pile(r, scene, c);
  if (c.group == "motor-hinge") return run_motor_hinge(r, scene, c);
  run_chain(r, scene, c);
}

}  // namespace soda
