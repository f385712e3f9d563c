// CanonicalWorld: construction from a scene, the step, state readout.
// Snapshots: canonical_snapshot.cpp; byte encoding: snapshot_bytes.cpp.
#include "soda/worlds/canonical_world.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

#include "canonical_world_parts.h"
#include "island_solver_settings.h"
#include "joint_factory.h"
#include "soda/worlds/bullet_allocator.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {

std::vector<std::size_t> resolve_insertion_order(const std::vector<std::size_t>& order, std::size_t count) {
  if (order.empty()) {
    std::vector<std::size_t> identity(count);
    std::iota(identity.begin(), identity.end(), std::size_t{0});
    return identity;
  }
  std::vector<bool> seen(count, false);
  bool ok = order.size() == count;
  for (std::size_t i : order) {
    if (!ok) break;
    ok = i < count && !seen[i];
    if (ok) seen[i] = true;
  }
  if (!ok)
    throw std::invalid_argument("CanonicalWorld: the insertion order must list every one of the " +
                                std::to_string(count) + " bodies exactly once");
  return order;
}

CanonicalWorld::CanonicalWorld(const Scene& scene, const std::vector<std::size_t>& insertion_order) {
  build(scene.settings);
  for (std::size_t i : resolve_insertion_order(insertion_order, scene.bodies.size()))
    insert_body(scene.bodies[i], nullptr);
  std::sort(entries_.begin(), entries_.end(),
            [](const auto& a, const auto& b) { return a->description.id < b->description.id; });
  for (std::size_t i = 1; i < entries_.size(); ++i)
    if (entries_[i]->description.id == entries_[i - 1]->description.id)
      throw std::invalid_argument("CanonicalWorld: duplicate body id " +
                                  std::to_string(entries_[i]->description.id));
  insert_joints(scene.joints, nullptr);
}

void CanonicalWorld::insert_joints(const std::vector<Joint>& joints, const std::vector<bool>* broken) {
  std::vector<std::size_t> order(joints.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return joints[x].id < joints[y].id; });
  auto find_body = [&](const Joint& j, BodyId id) -> btRigidBody& {
    auto it = std::lower_bound(entries_.begin(), entries_.end(), id,
                               [](const auto& e, BodyId x) { return e->description.id < x; });
    if (it == entries_.end() || (*it)->description.id != id)
      throw std::invalid_argument("CanonicalWorld: joint " + std::to_string(j.id) + " joins body " +
                                  std::to_string(id) + ", which is not in the world");
    return *(*it)->body;
  };
  for (std::size_t i : order) {
    const Joint& j = joints[i];
    if (!joints_.empty() && joints_.back()->description.id == j.id)
      throw std::invalid_argument("CanonicalWorld: duplicate joint id " + std::to_string(j.id));
    auto entry = std::make_unique<JointEntry>();
    entry->description = j;
    entry->constraint = make_constraint(j, find_body(j, j.body_a), find_body(j, j.body_b));
    if (broken && (*broken)[i]) entry->constraint->setEnabled(false);
    parts_->world.add_joint(entry->constraint.get(), j.collide_connected);
    joints_.push_back(std::move(entry));
  }
}

std::size_t CanonicalWorld::broken_joint_count() const {
  std::size_t n = 0;
  for (const auto& j : joints_) n += j->constraint->isEnabled() ? 0 : 1;
  return n;
}

// parts_ is declared after entries_: it goes first, while the bodies it
// reads in ~btCollisionWorld are alive (also when a constructor throws).
CanonicalWorld::~CanonicalWorld() = default;

void CanonicalWorld::build(const SceneSettings& settings) {
  settings_ = settings;
  install_bullet_allocator();
  parts_ = std::make_unique<CanonicalWorldParts>();
  parts_->world.setGravity(to_bt(settings_.gravity));
  configure_canonical_solver(parts_->world.getSolverInfo(), settings_);
}

// As make_rigid_body, but with a raw start transform when restoring: the
// world-space inertia is computed from the transform in the constructor.
void CanonicalWorld::insert_body(const Body& description, const BodyDynamicState* state) {
  if (description.id > kMaxBodyId)
    throw std::invalid_argument("CanonicalWorld: body id above kMaxBodyId");
  auto entry = std::make_unique<Entry>();
  entry->description = description;
  entry->shape = make_collision_shape(description.shape);
  if (!state) {
    entry->body = make_rigid_body(description, *entry->shape);
    if (description.kinematic)
      write_kinematic_state(*entry->body, description, settings_, steps_done_ * settings_.substeps);
  } else {
    // Activation state: restored after the manifolds (see import_manifolds).
    entry->body = make_body_from_state(description, *entry->shape, *state);
  }
  parts_->world.add_body(entry->body.get(), proxy_bits(description.collision_group),
                         proxy_bits(description.collision_mask));
  if (description.kinematic) kinematic_.push_back(entry.get());
  entries_.push_back(std::move(entry));
}

void CanonicalWorld::set_solver_defaults(SolverDefaults defaults) {
  solver_defaults_ = defaults;
  const bool bullet = defaults == SolverDefaults::Bullet;
  btContactSolverInfo& info = parts_->world.getSolverInfo();
  if (bullet)
    configure_bullet_solver(info, settings_);
  else
    configure_canonical_solver(info, settings_);
  parts_->world.set_bullet_defaults(bullet);
}

void CanonicalWorld::step() {
  // maxSubSteps = 0: exactly one internal step of h per call (as StockWorld).
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  // Kinematic bodies move to their next pose before the internal step
  // (collision detection and the solve see them there, with the velocity of
  // the move) and are written again after it: the solver writes their
  // velocities back and Bullet's updateActivationState their timers.
  const std::int64_t first = steps_done_ * settings_.substeps;
  for (int i = 0; i < settings_.substeps; ++i) {
    for (const Entry* e : kinematic_) write_kinematic_state(*e->body, e->description, settings_, first + i + 1);
    parts_->world.stepSimulation(h, 0, h);
    for (const Entry* e : kinematic_) write_kinematic_state(*e->body, e->description, settings_, first + i + 1);
  }
  ++steps_done_;
  if (parking_) park_settled_islands(parts_->parking, parts_->world, parts_->dispatcher, h);
}

void CanonicalWorld::set_solver_pool(std::shared_ptr<SolverPool> pool) { parts_->solver.set_pool(std::move(pool)); }

void CanonicalWorld::set_parking(bool on) {
  if (on == parking_) return;
  parking_ = on;
  if (on) {
    parts_->world.set_parking(&parts_->parking);
    // A scene's sleepers (Body::asleep) need not wait for the first step.
    park_lone_settled_bodies(parts_->parking, parts_->world, parts_->dispatcher,
                             btScalar(settings_.dt / settings_.substeps));
  } else {
    parts_->parking.unpark_all();
    parts_->world.set_parking(nullptr);
  }
}

std::size_t CanonicalWorld::parked_count() const { return parts_->parking.parked_bodies(); }

const StepStats& CanonicalWorld::last_step_stats() const { return parts_->world.stats(); }

std::vector<BodyState> CanonicalWorld::body_states() const {
  std::vector<BodyState> out;
  out.reserve(entries_.size());
  for (const auto& e : entries_) out.push_back(read_body_state(*e->body));
  return out;
}

std::uint64_t CanonicalWorld::state_hash(bool include_contacts) const {
  const std::uint64_t h = soda::state_hash(body_states());
  if (!include_contacts) return h;
  // Combine two FNV hashes into one (order matters: bodies first).
  return (h ^ contact_hash(contact_state())) * 1099511628211ull + 0x9e3779b97f4a7c15ull;
}

std::size_t CanonicalWorld::body_count() const { return entries_.size(); }

std::size_t CanonicalWorld::sleeping_count() const {
  std::size_t n = 0;
  for (const auto& e : entries_)
    if (!e->body->isStaticOrKinematicObject() && e->body->getActivationState() == ISLAND_SLEEPING) ++n;
  return n;
}

btDiscreteDynamicsWorld& CanonicalWorld::bullet() { return parts_->world; }

}  // namespace soda
