// Traces, trace files and error metrics (accuracy.h, docs/accuracy.md).
#include "soda/bench/accuracy.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>

#include <btBulletDynamicsCommon.h>
#include <nlohmann/json.hpp>

#include "soda/loadbalance/thread_clock.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"

namespace soda {
namespace {

constexpr int kSampleDoubles = 13;  // position 3, orientation 4, velocities 3 + 3
constexpr char kMagic[8] = {'S', 'O', 'D', 'A', 'T', 'R', 'C', '1'};

template <class W>
Trace trace_world(W& world, const Scene& scene, const TraceConfig& config) {
  Trace t;
  t.precision = kPrecisionName;
  t.world = world_kind_name(config.world);
  t.ccd = config.ccd;
  t.dt = scene.settings.dt;
  t.iterations = scene.settings.iterations;
  t.steps = config.steps;
  t.sample_period = config.sample_period;
  t.horizon = config.horizon;
  const double per = config.sample_period / scene.settings.dt;
  const int steps_per_sample = static_cast<int>(std::lround(per));
  if (steps_per_sample < 1 || std::abs(per - steps_per_sample) > 1e-6 * per)
    throw std::invalid_argument("accuracy: sample period " + std::to_string(config.sample_period) +
                                " s is not a whole number of steps of dt " + std::to_string(scene.settings.dt));
  btDispatcher& dispatcher = *world.bullet().getDispatcher();
  const EnergyTable energy(scene);

  auto sample = [&](int step) {
    const std::vector<BodyState> raw = world.body_states();
    const std::vector<BodySample> s = to_samples(scene, raw);
    const double time = step * scene.settings.dt;
    t.times.push_back(time);
    t.energy.push_back(energy.energy(s));
    if (time <= config.horizon + 1e-9) t.horizon_states.push_back(s);
    return raw;
  };
  sample(0);
  double wall = 0;
  for (int k = 1; k <= config.steps; ++k) {
    const std::int64_t a = wall_ns();
    world.step();
    wall += static_cast<double>(wall_ns() - a) * 1e-9;
    t.penetration.add(manifold_penetration(dispatcher));
    const bool sample_now = k % steps_per_sample == 0 || k == config.steps;
    if (!sample_now) continue;
    const std::vector<BodyState> raw = sample(k);
    if (!std::all_of(raw.begin(), raw.end(), is_finite)) {
      t.first_nonfinite_step = k;  // the defined response: stop, report the step
      t.steps = k;
      break;
    }
  }
  t.wall_seconds = wall;
  const std::vector<BodyState> raw = world.body_states();
  t.final_states = to_samples(scene, raw);
  t.state_hash = state_hash(raw);
  t.sleeping = world.sleeping_count();
  return t;
}

void put_doubles(std::ofstream& out, const double* v, std::size_t n) {
  out.write(reinterpret_cast<const char*>(v), static_cast<std::streamsize>(n * sizeof(double)));
}

void put_sample(std::ofstream& out, const BodySample& s) {
  double v[kSampleDoubles];
  std::memcpy(v, s.position, 3 * sizeof(double));
  std::memcpy(v + 3, s.orientation, 4 * sizeof(double));
  std::memcpy(v + 7, s.linear_velocity, 3 * sizeof(double));
  std::memcpy(v + 10, s.angular_velocity, 3 * sizeof(double));
  put_doubles(out, v, kSampleDoubles);
}

struct Reader {
  std::ifstream in;
  std::string path;
  void get(void* p, std::size_t bytes) {
    in.read(static_cast<char*>(p), static_cast<std::streamsize>(bytes));
    if (!in) throw std::runtime_error(path + ": truncated trace file");
  }
  BodySample sample(BodyId id) {
    double v[kSampleDoubles];
    get(v, sizeof v);
    BodySample s;
    s.id = id;
    std::memcpy(s.position, v, 3 * sizeof(double));
    std::memcpy(s.orientation, v + 3, 4 * sizeof(double));
    std::memcpy(s.linear_velocity, v + 7, 3 * sizeof(double));
    std::memcpy(s.angular_velocity, v + 10, 3 * sizeof(double));
    return s;
  }
};

Eigen::Vector3d vec(const double* p) { return {p[0], p[1], p[2]}; }
Eigen::Quaterniond quat(const double* q) { return Eigen::Quaterniond(q[3], q[0], q[1], q[2]); }

// Half height of the world AABB of a shape in orientation q.
double aabb_half_y(const Shape& shape, const Eigen::Quaterniond& q) {
  if (shape.kind == ShapeKind::Sphere) return shape.radius;
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();
  const Vec3 h = shape.local_half_extents();
  return std::abs(r(1, 0)) * h.x() + std::abs(r(1, 1)) * h.y() + std::abs(r(1, 2)) * h.z();
}

void check_same_bodies(const std::vector<BodySample>& a, const std::vector<BodySample>& b) {
  if (a.size() != b.size()) throw std::invalid_argument("compare_traces: traces hold different bodies");
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].id != b[i].id) throw std::invalid_argument("compare_traces: traces hold different bodies");
}

}  // namespace

bool is_finite(const BodyState& s) {
  for (btScalar v : s.basis)
    if (!std::isfinite(static_cast<double>(v))) return false;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(static_cast<double>(s.origin[i])) ||
        !std::isfinite(static_cast<double>(s.linear_velocity[i])) ||
        !std::isfinite(static_cast<double>(s.angular_velocity[i])))
      return false;
  return true;
}

// Smallest distance from a shape's centre to its surface: CCD's natural scale.
void enable_ccd(btDiscreteDynamicsWorld& world, const Scene& scene) {
  std::map<BodyId, const Body*> by_id;
  for (const Body& b : scene.bodies) by_id[b.id] = &b;
  for (int i = 0; i < world.getNumCollisionObjects(); ++i) {
    btCollisionObject* o = world.getCollisionObjectArray()[i];
    if (o->isStaticOrKinematicObject()) continue;
    const double r = inner_radius(by_id.at(static_cast<BodyId>(o->getUserIndex()))->shape);
    o->setCcdMotionThreshold(btScalar(r));
    o->setCcdSweptSphereRadius(btScalar(0.9 * r));
  }
}

void PenetrationStats::add(const PenetrationStats& o) {
  max = std::max(max, o.max);
  sum += o.sum;
  points += o.points;
}

PenetrationStats manifold_penetration(btDispatcher& dispatcher) {
  PenetrationStats s;
  const int n = dispatcher.getNumManifolds();
  for (int i = 0; i < n; ++i) {
    const btPersistentManifold* m = dispatcher.getManifoldByIndexInternal(i);
    for (int p = 0; p < m->getNumContacts(); ++p) {
      const double depth = std::max(0.0, -static_cast<double>(m->getContactPoint(p).getDistance()));
      s.max = std::max(s.max, depth);
      s.sum += depth;
      ++s.points;
    }
  }
  return s;
}

std::vector<BodySample> to_samples(const Scene& scene, const std::vector<BodyState>& states) {
  std::map<BodyId, bool> is_static;
  for (const Body& b : scene.bodies) is_static[b.id] = b.is_static;
  std::vector<BodySample> out;
  out.reserve(states.size());
  for (const BodyState& s : states) {
    const auto it = is_static.find(s.id);
    if (it == is_static.end() || it->second) continue;
    BodySample b;
    b.id = s.id;
    Eigen::Matrix3d r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = static_cast<double>(s.basis[i * 3 + j]);
    Eigen::Quaterniond q(r);
    q.normalize();
    b.orientation[0] = q.x();
    b.orientation[1] = q.y();
    b.orientation[2] = q.z();
    b.orientation[3] = q.w();
    for (int i = 0; i < 3; ++i) {
      b.position[i] = static_cast<double>(s.origin[i]);
      b.linear_velocity[i] = static_cast<double>(s.linear_velocity[i]);
      b.angular_velocity[i] = static_cast<double>(s.angular_velocity[i]);
    }
    out.push_back(b);
  }
  std::sort(out.begin(), out.end(), [](const BodySample& a, const BodySample& b) { return a.id < b.id; });
  return out;
}

Trace record_trace(const Scene& scene, const TraceConfig& config) {
  if (config.steps < 0) throw std::invalid_argument("accuracy: steps must be >= 0");
  switch (config.world) {
    case WorldKind::Stock: {
      StockWorld world(scene);
      if (config.ccd) enable_ccd(world.bullet(), scene);
      return trace_world(world, scene, config);
    }
    case WorldKind::Canonical: {
      if (config.ccd)
        throw std::invalid_argument(
            "accuracy: CCD is outside the canonical world's contract; use the stock world for CCD");
      CanonicalWorld world(scene);
      return trace_world(world, scene, config);
    }
  }
  throw std::invalid_argument("accuracy: unknown world kind");
}

void write_trace(const Trace& t, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  const std::size_t bodies = t.final_states.size();
  nlohmann::json h = {{"precision", t.precision},
                      {"world", t.world},
                      {"ccd", t.ccd},
                      {"dt", t.dt},
                      {"iterations", t.iterations},
                      {"steps", t.steps},
                      {"sample_period", t.sample_period},
                      {"horizon", t.horizon},
                      {"wall_seconds", t.wall_seconds},
                      {"state_hash", t.state_hash},
                      {"sleeping", t.sleeping},
                      {"first_nonfinite_step", t.first_nonfinite_step},
                      {"pen_max", t.penetration.max},
                      {"pen_sum", t.penetration.sum},
                      {"pen_points", t.penetration.points},
                      {"samples", t.times.size()},
                      {"horizon_samples", t.horizon_states.size()},
                      {"bodies", bodies}};
  const std::string header = h.dump();
  const std::uint64_t len = header.size();
  out.write(kMagic, sizeof kMagic);
  out.write(reinterpret_cast<const char*>(&len), sizeof len);
  out.write(header.data(), static_cast<std::streamsize>(len));
  for (const BodySample& s : t.final_states) {
    const std::uint32_t id = s.id;
    out.write(reinterpret_cast<const char*>(&id), sizeof id);
  }
  put_doubles(out, t.times.data(), t.times.size());
  put_doubles(out, t.energy.data(), t.energy.size());
  for (const auto& states : t.horizon_states) {
    if (states.size() != bodies) throw std::logic_error("write_trace: body count changed within a trace");
    for (const BodySample& s : states) put_sample(out, s);
  }
  for (const BodySample& s : t.final_states) put_sample(out, s);
  out.close();
  if (!out) throw std::runtime_error(path + ": write failed");
}

Trace read_trace(const std::string& path) {
  Reader r{std::ifstream(path, std::ios::binary), path};
  if (!r.in) throw std::runtime_error(path + ": cannot open trace file");
  char magic[8];
  r.get(magic, sizeof magic);
  if (std::memcmp(magic, kMagic, sizeof magic) != 0) throw std::runtime_error(path + ": not a SODA trace file");
  std::uint64_t len = 0;
  r.get(&len, sizeof len);
  if (len > (1u << 20)) throw std::runtime_error(path + ": bad trace header length");
  std::string header(len, '\0');
  r.get(header.data(), len);
  Trace t;
  const nlohmann::json h = nlohmann::json::parse(header);
  t.precision = h.at("precision");
  t.world = h.at("world");
  t.ccd = h.at("ccd");
  t.dt = h.at("dt");
  t.iterations = h.at("iterations");
  t.steps = h.at("steps");
  t.sample_period = h.at("sample_period");
  t.horizon = h.at("horizon");
  t.wall_seconds = h.at("wall_seconds");
  t.state_hash = h.at("state_hash");
  t.sleeping = h.at("sleeping");
  t.first_nonfinite_step = h.at("first_nonfinite_step");
  t.penetration.max = h.at("pen_max");
  t.penetration.sum = h.at("pen_sum");
  t.penetration.points = h.at("pen_points");
  const std::size_t samples = h.at("samples"), horizon_samples = h.at("horizon_samples"), bodies = h.at("bodies");
  std::vector<BodyId> ids(bodies);
  for (BodyId& id : ids) {
    std::uint32_t v = 0;
    r.get(&v, sizeof v);
    id = v;
  }
  t.times.resize(samples);
  t.energy.resize(samples);
  r.get(t.times.data(), samples * sizeof(double));
  r.get(t.energy.data(), samples * sizeof(double));
  t.horizon_states.resize(horizon_samples);
  for (auto& states : t.horizon_states)
    for (BodyId id : ids) states.push_back(r.sample(id));
  for (BodyId id : ids) t.final_states.push_back(r.sample(id));
  return t;
}

std::vector<std::pair<BodyId, MassProperties>> mass_table(const Scene& scene) {
  std::vector<std::pair<BodyId, MassProperties>> out;
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    MassProperties m;
    m.mass = b.mass;
    m.shape = b.shape;
    const auto shape = make_collision_shape(b.shape);
    btVector3 inertia(0, 0, 0);
    shape->calculateLocalInertia(btScalar(b.mass), inertia);
    for (int i = 0; i < 3; ++i) m.inertia[i] = static_cast<double>(inertia[i]);
    out.emplace_back(b.id, m);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

double body_energy(const MassProperties& m, const BodySample& s, const Vec3& gravity) {
  const Vec3 v = vec(s.linear_velocity), w = vec(s.angular_velocity), x = vec(s.position);
  // Rotational: 1/2 w_b^T I w_b with w_b = R^T w the angular velocity in the body frame.
  const Vec3 wb = quat(s.orientation).normalized().toRotationMatrix().transpose() * w;
  const double rot = 0.5 * (m.inertia[0] * wb.x() * wb.x() + m.inertia[1] * wb.y() * wb.y() +
                            m.inertia[2] * wb.z() * wb.z());
  return 0.5 * m.mass * v.squaredNorm() + rot - m.mass * gravity.dot(x);
}

EnergyTable::EnergyTable(const Scene& scene) : gravity_(scene.settings.gravity) {
  for (auto& [id, m] : mass_table(scene)) table_.emplace(id, m);
}

double EnergyTable::energy(const std::vector<BodySample>& states) const {
  double e = 0;
  for (const BodySample& s : states) {
    const auto it = table_.find(s.id);
    if (it == table_.end())
      throw std::invalid_argument("total_energy: body " + std::to_string(s.id) + " is not a dynamic body of the scene");
    e += body_energy(it->second, s, gravity_);
  }
  return e;
}

double total_energy(const Scene& scene, const std::vector<BodySample>& states) {
  return EnergyTable(scene).energy(states);
}

std::vector<HeightCell> height_profile(const Scene& scene, const std::vector<BodySample>& states, double cell) {
  std::map<BodyId, const Body*> by_id;
  for (const Body& b : scene.bodies) by_id[b.id] = &b;
  std::map<std::pair<std::int64_t, std::int64_t>, double> top;
  for (const BodySample& s : states) {
    const Body& b = *by_id.at(s.id);
    const auto key = std::make_pair(static_cast<std::int64_t>(std::floor(s.position[0] / cell)),
                                    static_cast<std::int64_t>(std::floor(s.position[2] / cell)));
    const double y = s.position[1] + aabb_half_y(b.shape, quat(s.orientation));
    auto [it, inserted] = top.emplace(key, y);
    if (!inserted) it->second = std::max(it->second, y);
  }
  std::vector<HeightCell> out;
  for (const auto& [key, y] : top) out.push_back({key.first, key.second, y});
  return out;
}

Vec3 centre_of_mass(const Scene& scene, const std::vector<BodySample>& states) {
  std::map<BodyId, double> mass;
  for (const Body& b : scene.bodies) mass[b.id] = b.mass;
  Vec3 sum = Vec3::Zero();
  double total = 0;
  for (const BodySample& s : states) {
    const double m = mass.at(s.id);
    sum += m * vec(s.position);
    total += m;
  }
  return total > 0 ? Vec3(sum / total) : Vec3::Zero();
}

ErrorMetrics compare_traces(const Scene& scene, const Trace& run, const Trace& ref, const MetricOptions& options) {
  check_same_bodies(run.final_states, ref.final_states);
  if (std::abs(run.sample_period - ref.sample_period) > 1e-12)
    throw std::invalid_argument("compare_traces: traces have different sample periods");
  ErrorMetrics e;
  // Short horizon: samples both traces hold (same period: same times).
  const std::size_t samples = std::min(run.horizon_states.size(), ref.horizon_states.size());
  double sq = 0, ang_sq = 0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < samples; ++k) {
    check_same_bodies(run.horizon_states[k], ref.horizon_states[k]);
    for (std::size_t i = 0; i < run.horizon_states[k].size(); ++i) {
      const BodySample& a = run.horizon_states[k][i];
      const BodySample& b = ref.horizon_states[k][i];
      const double d = (vec(a.position) - vec(b.position)).norm();
      // Rotation angle of a^-1 b (atan2: exact 0 for equal orientations, accurate near 0).
      const Eigen::Quaterniond r = quat(a.orientation).normalized().conjugate() * quat(b.orientation).normalized();
      const double angle = 2.0 * std::atan2(r.vec().norm(), std::abs(r.w()));
      sq += d * d;
      ang_sq += angle * angle;
      e.traj_max = std::max(e.traj_max, d);
      ++count;
    }
  }
  if (count > 0) {
    e.traj_rms = std::sqrt(sq / static_cast<double>(count));
    e.angle_rms = std::sqrt(ang_sq / static_cast<double>(count));
  }
  e.pen_max = run.penetration.max;
  e.pen_mean = run.penetration.mean();
  if (!run.energy.empty() && run.energy.front() != 0)
    e.energy_drift = (run.energy.back() - run.energy.front()) / std::abs(run.energy.front());
  if (!run.energy.empty() && run.energy.front() != 0)
    for (double en : run.energy)
      e.energy_gain = std::max(e.energy_gain, (en - run.energy.front()) / std::abs(run.energy.front()));
  if (!run.energy.empty() && !ref.energy.empty() && ref.energy.front() != 0)
    e.energy_err = (run.energy.back() - ref.energy.back()) / std::abs(ref.energy.front());
  auto on_ground = [&](const std::vector<BodySample>& v, int& lost) {
    std::vector<BodySample> out;
    for (const BodySample& b : v) {
      if (b.position[1] < options.lost_below) {
        ++lost;
        continue;
      }
      out.push_back(b);
    }
    return out;
  };
  const std::vector<BodySample> run_final = on_ground(run.final_states, e.lost_bodies);
  const std::vector<BodySample> ref_final = on_ground(ref.final_states, e.ref_lost_bodies);
  e.com_err = (centre_of_mass(scene, run_final) - centre_of_mass(scene, ref_final)).norm();
  // Height profiles on the union of occupied cells (an empty cell: the ground, y = 0).
  std::map<std::pair<std::int64_t, std::int64_t>, std::pair<double, double>> cells;
  double top_run = 0, top_ref = 0;
  for (const HeightCell& c : height_profile(scene, run_final, options.profile_cell)) {
    cells[{c.i, c.k}].first = c.top;
    top_run = std::max(top_run, c.top);
  }
  for (const HeightCell& c : height_profile(scene, ref_final, options.profile_cell)) {
    cells[{c.i, c.k}].second = c.top;
    top_ref = std::max(top_ref, c.top);
  }
  double hsq = 0;
  for (const auto& [key, tops] : cells) hsq += (tops.first - tops.second) * (tops.first - tops.second);
  if (!cells.empty()) e.height_rms = std::sqrt(hsq / static_cast<double>(cells.size()));
  e.top_err = top_run - top_ref;
  double fsq = 0;
  std::size_t both = 0;
  for (std::size_t i = 0; i < run.final_states.size(); ++i) {
    if (run.final_states[i].position[1] < options.lost_below || ref.final_states[i].position[1] < options.lost_below)
      continue;
    fsq += (vec(run.final_states[i].position) - vec(ref.final_states[i].position)).squaredNorm();
    ++both;
  }
  if (both > 0) e.final_rms = std::sqrt(fsq / static_cast<double>(both));
  return e;
}

}  // namespace soda
