// bench/ — accuracy: traces of a run and the error metrics of a run against
// a reference (docs/accuracy.md, BENCHMARKS.md "Accuracy").
//
// A Trace is what a run leaves behind for comparison: per-body states at
// fixed sample times inside a short horizon, the final states, the total
// energy at every sample time and penetration statistics over every step.
// Traces are plain doubles (btScalar converts exactly to double), so a float
// run can be compared with a double reference that ran in another process
// (write_trace / read_trace; float and double are separate binaries).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "soda/runtime/run.h"
#include "soda/scene/scene.h"

class btDispatcher;
class btDiscreteDynamicsWorld;

namespace soda {

/// Pose and velocities of one body in double (exact conversion from btScalar).
struct BodySample {
  BodyId id = 0;
  double position[3] = {0, 0, 0};
  double orientation[4] = {0, 0, 0, 1};  // unit quaternion x, y, z, w
  double linear_velocity[3] = {0, 0, 0};
  double angular_velocity[3] = {0, 0, 0};
};

/// Penetration depth of contact points: depth = max(0, -distance) of every
/// point of every persistent manifold, read after every step (the distances
/// are the narrowphase's, i.e. of the positions at the start of that step).
struct PenetrationStats {
  double max = 0;           // m
  double sum = 0;           // m, over every point of every step
  std::int64_t points = 0;  // contact points seen (penetrating or not)
  double mean() const { return points > 0 ? sum / static_cast<double>(points) : 0.0; }
  void add(const PenetrationStats& o);
};

/// Scans the manifolds a dispatcher holds (does not change them).
PenetrationStats manifold_penetration(btDispatcher& dispatcher);

/// Every field of a raw state is finite (no NaN, no Inf).
bool is_finite(const BodyState& state);

/// Turns continuous collision detection on for every dynamic body of a stock
/// world: motion threshold = inner radius, swept sphere radius = 0.9 x inner
/// radius (Bullet's CcdPhysicsDemo settings). Not for canonical worlds.
void enable_ccd(btDiscreteDynamicsWorld& world, const Scene& scene);

struct TraceConfig {
  WorldKind world = WorldKind::Canonical;
  int steps = 600;
  /// Continuous collision detection on every dynamic body (Stock world only:
  /// CCD is outside the canonical world's contract; invalid_argument there).
  /// Motion threshold = the body's inner radius, swept sphere = 0.9 of it.
  bool ccd = false;
  double sample_period = 1.0 / 30.0;  // s; must be a whole number of steps
  double horizon = 1.0;               // s; per-body states kept for t <= horizon
};

struct Trace {
  // What ran.
  std::string precision;  // "float" | "double"
  std::string world;      // "canonical" | "stock"
  bool ccd = false;
  double dt = 0;
  int iterations = 0;
  int steps = 0;
  double sample_period = 0;
  double horizon = 0;
  // Results.
  std::vector<double> times;    // sample times 0, period, ...; the last is the end of the run
  std::vector<double> energy;   // total energy (J) at each sample time
  std::vector<std::vector<BodySample>> horizon_states;  // dynamic bodies by id, at times[i] <= horizon
  std::vector<BodySample> final_states;                 // dynamic bodies by id, at the end
  PenetrationStats penetration;
  double wall_seconds = 0;      // world.step() calls only
  std::uint64_t state_hash = 0; // soda::state_hash of the final raw states
  std::size_t sleeping = 0;     // at the end
  std::int64_t first_nonfinite_step = -1;  // -1: every state finite; else the run stopped there
};

/// Builds the world of config.world on `scene` and steps it config.steps
/// times, sampling as described above. The scene's settings (dt,
/// iterations) are used as they are. Throws std::invalid_argument for a
/// sample period that is not a whole number of steps, or CCD on a canonical
/// world.
Trace record_trace(const Scene& scene, const TraceConfig& config);

/// Binary trace file (magic, a JSON header, raw little-endian doubles). Round
/// trip is exact. read_trace throws std::runtime_error naming the path.
void write_trace(const Trace& trace, const std::string& path);
Trace read_trace(const std::string& path);

/// Mass properties of a dynamic body as Bullet computes them.
struct MassProperties {
  double mass = 0;
  double inertia[3] = {0, 0, 0};  // principal, body frame (Bullet's calculateLocalInertia)
  Shape shape;
};
/// Dynamic bodies of a scene by id (statics are left out).
std::vector<std::pair<BodyId, MassProperties>> mass_table(const Scene& scene);

/// Kinetic (translational + rotational) plus potential energy -m g.x of one
/// body, in J; gravity in m/s^2.
double body_energy(const MassProperties& m, const BodySample& s, const Vec3& gravity);
/// Sum of body_energy over `states` (dynamic bodies; ids not in the scene throw).
double total_energy(const Scene& scene, const std::vector<BodySample>& states);

/// total_energy with the mass table built once (for per-step use).
class EnergyTable {
 public:
  explicit EnergyTable(const Scene& scene);
  double energy(const std::vector<BodySample>& states) const;

 private:
  Vec3 gravity_;
  std::map<BodyId, MassProperties> table_;
};

/// Error metrics of a run against a reference on the same scene and horizon.
struct ErrorMetrics {
  // Short horizon: every dynamic body at every sample time t <= horizon.
  double traj_rms = 0;        // m, RMS of |x - x_ref|
  double traj_max = 0;        // m
  double angle_rms = 0;       // rad, RMS rotation angle between orientations
  // The run's own penetration (true penetration is zero).
  double pen_max = 0;         // m
  double pen_mean = 0;        // m
  // Energy: E = kinetic + potential (zero at y = 0 for gravity along -y).
  double energy_drift = 0;    // (E_end - E_0) / |E_0| of the run itself
  double energy_err = 0;      // (E_end - E_ref,end) / |E_ref,0|
  double energy_gain = 0;     // max over sample times of (E(t) - E_0) / |E_0|, >= 0: energy a
                              // dissipative scene should never gain (e.g. from depenetration)
  // Final pile statistics, over the bodies still on the ground (centre above
  // MetricOptions::lost_below); bodies that slid off the ground's edge and
  // fell are counted instead.
  double com_err = 0;         // m, |centre of mass - reference's| at the end
  double height_rms = 0;      // m, RMS over height-profile cells (either run occupies) of the top-height difference
  double top_err = 0;         // m, highest point minus the reference's highest point
  double final_rms = 0;       // m, RMS final position error per body on the ground in both (chaotic: for information)
  int lost_bodies = 0;        // bodies of the run below lost_below at the end
  int ref_lost_bodies = 0;    // the same in the reference
};

struct MetricOptions {
  double profile_cell = 2.0;  // m, edge of the x-z cells of the height profile
  double lost_below = -1.0;   // m; the registry scenes' ground top is y = 0
};

/// Compares `run` with `ref`; they must trace the same bodies with the same
/// sample period (std::invalid_argument otherwise).
ErrorMetrics compare_traces(const Scene& scene, const Trace& run, const Trace& ref,
                            const MetricOptions& options = {});

/// Height profile: cell (i, k) of edge `cell` in x-z -> highest point (m) of
/// the bodies whose centre lies in it (top of their world AABB).
struct HeightCell {
  std::int64_t i = 0, k = 0;
  double top = 0;
};
std::vector<HeightCell> height_profile(const Scene& scene, const std::vector<BodySample>& states, double cell);
/// Mass-weighted centre of the dynamic bodies.
Vec3 centre_of_mass(const Scene& scene, const std::vector<BodySample>& states);

/// Converts raw Bullet states (dynamic bodies only are kept, sorted by id).
std::vector<BodySample> to_samples(const Scene& scene, const std::vector<BodyState>& states);

}  // namespace soda
