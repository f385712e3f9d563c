// TerritoryWorld: its part of the scene's state at a step boundary, and a
// world rebuilt from the whole scene's state.
//
// Why a rebuilt world steps exactly as the original: the state a step reads
// is the bodies' raw states and the contact state (world_snapshot.h); ghosts
// are rewritten from their owners' records at every step (invariant 2), and
// every manifold with points goes to the kept store of its key body's owner,
// which is where migration puts it too (territory_migrate.cpp): the next
// step attaches it to the key body's ghosts and seeds it into whichever
// world holds the pair before narrowphase (territory_collide.cpp), with the
// values a live manifold would have held.
#include <algorithm>
#include <string>

#include "soda/scene/kinematic_command.h"
#include "canonical_dynamics_world.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"
#include "watchdog_scan.h"

namespace soda {
namespace {

// Every value of a pair with `id` (a removed body's, or one whose filter
// changed: its pairs end).
void erase_pairs_of(std::map<std::pair<BodyId, BodyId>, ManifoldState>& values, BodyId id) {
  std::erase_if(values, [id](const auto& v) { return v.first.first == id || v.first.second == id; });
}

}  // namespace

TerritoryWorld::TerritoryWorld(const WorldSnapshot& snapshot, WorldId id, TerritoryMap map,
                               std::int64_t internal_steps_done, const TerritoryWorld* share_pools_of)
    : id_(id), map_(std::move(map)), settings_(snapshot.settings) {
  init_world(share_pools_of);
  steps_done_ = internal_steps_done >= 0 ? internal_steps_done : snapshot.steps_done * settings_.substeps;
  std::vector<const Body*> dynamic;
  std::vector<const BodyDynamicState*> states;
  std::vector<Body> fixed;
  for (const BodySnapshot& b : snapshot.bodies) {
    const Body& d = b.description;
    if (d.id > kMaxBodyId) throw PartitionError("TerritoryWorld: body id above kMaxBodyId");
    if (d.is_static && !d.kinematic) {
      fixed.push_back(d);
      continue;
    }
    if (d.is_static) {
      // A rollback's rebuild: the world it replaces has every command of
      // its kinematic bodies applied so far, pose and filter (the
      // snapshot's statics may be the scene's); commands are keyed by step
      // and never change.
      const Entry* old = nullptr;
      if (d.kinematic && share_pools_of)
        if (auto it = share_pools_of->entries_.find(d.id); it != share_pools_of->entries_.end()) old = it->second.get();
      if (old && commanded(old->description)) {
        Body merged = d;
        merge_commands(merged.commands, old->description.commands);
        merge_commands(merged.filter_commands, old->description.filter_commands);
        insert_static(merged);
      } else {
        insert_static(d);
      }
      continue;
    }
    dynamic.push_back(&d);
    states.push_back(&b.state);
  }
  // A rollback's rebuild keeps the catalog of the world it replaces: the
  // fixed statics of a scene never change.
  std::shared_ptr<const StaticCatalog> catalog;
  if (share_pools_of && share_pools_of->parts_->statics.catalog->size() == fixed.size())
    catalog = share_pools_of->parts_->statics.catalog;
  parts_->statics.init(catalog ? std::move(catalog) : std::make_shared<const StaticCatalog>(std::move(fixed)));
  insert_owned_and_joints(dynamic, states, snapshot.joints);
  for (const ManifoldState& m : snapshot.manifolds) {
    if (!entries_.count(m.id0) && !entries_.count(m.id1)) continue;  // neither body here
    if (!owns(key_of(m.id0, m.id1))) {
      if (!m.points.empty() && (owns(m.id0) || owns(m.id1))) contacts_kept_elsewhere_ = true;
      continue;
    }
    if (!kept_.emplace(PairKey{m.id0, m.id1}, m).second)
      throw PartitionError("TerritoryWorld: two contact states for pair " + std::to_string(m.id0) + "-" +
                           std::to_string(m.id1) + " in a snapshot");
  }
  if (share_pools_of && share_pools_of->id_ == id_ && share_pools_of->map_ == map_) {
    interior_ = share_pools_of->interior_;  // a rollback's rebuild: same territory, same cells
    sort_lists();
  } else {
    init_interior();
  }
  if (share_pools_of) set_parking(share_pools_of->parking());
}

WorldSnapshot TerritoryWorld::part_snapshot() const {
  WorldSnapshot s;
  part_snapshot(s);
  return s;
}

// Reuses `out`'s storage (speculation keeps one per step: no allocation
// once the kept states recycle).
void TerritoryWorld::part_snapshot(WorldSnapshot& out) const { snapshot_into(out, true); }

// Between collide() and finish_islands() the kept store still holds the
// values of the step's start, some of them seeded into pairs held here
// since: the live manifolds alone are the state as solved.
bool TerritoryWorld::solved_state(LocalIslands& islands, WorldSnapshot& out) const {
  if (parts_->replay.armed() && !parts_->replay.mid_step() && parts_->replay.pending()) return false;
  islands = local_islands_;
  snapshot_into(out, false);
  return true;
}

void TerritoryWorld::snapshot_into(WorldSnapshot& out, bool with_kept) const {
  out.settings = settings_;
  out.steps_done = steps_done_ / settings_.substeps;
  // By id. Sorting pointers, not the snapshots (large: every speculative
  // checkpoint spent 1400 instructions a body swapping them).
  const std::vector<const Entry*> order = all_owned_by_id();
  out.bodies.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    out.bodies[i] = BodySnapshot{order[i]->description, read_dynamic_state(*order[i]->body)};
  std::size_t n = 0;
  auto next = [&]() -> ManifoldState& {
    if (n == out.manifolds.size()) out.manifolds.emplace_back();
    return out.manifolds[n++];
  };
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() > 0) read_manifold_state(*m, next());
  }
  if (with_kept)
    for (const auto& [pair, state] : kept_) next() = state;
  out.manifolds.resize(n);
  parts_->parking.append_contacts(out.manifolds);  // held here, out of the world
  out.joints.resize(joints_.size());
  std::size_t j = 0;
  for (const auto& [id, held] : joints_)
    out.joints[j++] = JointSnapshot{held->description, !held->constraint->isEnabled()};
  std::sort(out.manifolds.begin(), out.manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
  });
}

std::vector<BodySnapshot> TerritoryWorld::static_snapshots() const {
  std::vector<BodySnapshot> out;
  const StaticCatalog& catalog = *parts_->statics.catalog;
  for (std::size_t i = 0; i < catalog.size(); ++i) out.push_back(BodySnapshot{catalog.body(i), catalog.state(i)});
  for (const Entry* e : statics_)
    if (e->description.kinematic) out.push_back(BodySnapshot{e->description, read_dynamic_state(*e->body)});
  std::sort(out.begin(), out.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
    return a.description.id < b.description.id;
  });
  return out;
}

std::vector<WatchdogFinding> TerritoryWorld::watchdog_findings(const WatchdogLimits& limits) const {
  std::vector<WatchdogFinding> out;
  for (const Entry* e : owned_) watchdog_scan_body(*e->body, e->id(), limits, out);
  watchdog_scan_manifolds(parts_->dispatcher, limits, out);
  watchdog_sort(out);
  return out;
}

bool TerritoryWorld::set_velocity(BodyId id, const Vec3& linear, const Vec3& angular) {
  auto it = entries_.find(id);
  if (it == entries_.end() || it->second->role != Role::Owned) return false;
  unpark_for_input(*it->second);
  quiet_ = -1;
  btRigidBody& rb = *it->second->body;
  rb.setLinearVelocity(btVector3(btScalar(linear.x()), btScalar(linear.y()), btScalar(linear.z())));
  rb.setAngularVelocity(btVector3(btScalar(angular.x()), btScalar(angular.y()), btScalar(angular.z())));
  rb.forceActivationState(ACTIVE_TAG);
  rb.setDeactivationTime(btScalar(0));
  return true;
}

bool TerritoryWorld::apply_impulse(BodyId id, const Vec3& impulse) {
  auto it = entries_.find(id);
  if (it == entries_.end() || it->second->role != Role::Owned) return false;
  unpark_for_input(*it->second);
  quiet_ = -1;
  btRigidBody& rb = *it->second->body;
  rb.applyCentralImpulse(btVector3(btScalar(impulse.x()), btScalar(impulse.y()), btScalar(impulse.z())));
  rb.forceActivationState(ACTIVE_TAG);
  rb.setDeactivationTime(btScalar(0));
  return true;
}

void TerritoryWorld::set_gravity(const Vec3& gravity) {
  settings_.gravity = gravity;
  quiet_ = -1;
  const btVector3 g = to_bt(gravity);
  // The world's, for bodies added later (addRigidBody), and every body's
  // own: btDiscreteDynamicsWorld::setGravity skips inactive bodies, and a
  // sleeper must wake with the gravity a body rebuilt from a snapshot or a
  // migration gets.
  parts_->world.setGravity(g);
  for (const auto& [id, e] : entries_)
    if (e->role != Role::Static) e->body->setGravity(g);
}

bool TerritoryWorld::command_kinematic(BodyId id, const KinematicCommand& command) {
  auto it = entries_.find(id);
  if (it == entries_.end() || !it->second->description.kinematic) return false;
  record_command(it->second->description.commands, command);
  quiet_ = -1;
  return true;
}

bool TerritoryWorld::set_pose(BodyId id, const Pose& pose) {
  auto it = entries_.find(id);
  if (it == entries_.end() || it->second->role != Role::Owned) return false;
  unpark_for_input(*it->second);
  quiet_ = -1;
  btRigidBody& rb = *it->second->body;
  const btTransform t = to_bt_transform(pose.position, pose.orientation);
  rb.setWorldTransform(t);
  rb.setInterpolationWorldTransform(t);
  rb.updateInertiaTensor();
  rb.forceActivationState(ACTIVE_TAG);
  rb.setDeactivationTime(btScalar(0));
  return true;
}

TerritoryWorld::Entry* TerritoryWorld::owned_for_input(BodyId id) {
  auto it = entries_.find(id);
  if (it == entries_.end() || it->second->role != Role::Owned) return nullptr;
  unpark_for_input(*it->second);
  quiet_ = -1;
  return it->second.get();
}

// A property input: the description first (what every copy of the body
// elsewhere is built from), then the Bullet body.
bool TerritoryWorld::set_mass(BodyId id, double mass) {
  Entry* e = owned_for_input(id);
  if (!e) return false;
  e->description.mass = mass;
  apply_material(*e->body, e->description, to_bt(settings_.gravity));
  return true;
}

bool TerritoryWorld::set_friction(BodyId id, double friction) {
  Entry* e = owned_for_input(id);
  if (!e) return false;
  e->description.friction = friction;
  apply_material(*e->body, e->description, to_bt(settings_.gravity));
  return true;
}

bool TerritoryWorld::set_restitution(BodyId id, double restitution) {
  Entry* e = owned_for_input(id);
  if (!e) return false;
  e->description.restitution = restitution;
  apply_material(*e->body, e->description, to_bt(settings_.gravity));
  return true;
}

bool TerritoryWorld::set_user_data(BodyId id, std::uint64_t user_data) {
  Entry* e = owned_for_input(id);
  if (!e) return false;
  e->description.user_data = user_data;
  return true;
}

// In every world at the same boundary (the runtime's apply_inputs): every
// copy of the body leaves the broadphase and comes back with the new filter,
// so each of its pairs, with its manifold, ends wherever it was held, and no
// world keeps contact state for them. Pairs that pass the filter begin
// again at the next collide, as in one world.
bool TerritoryWorld::set_collision_filter(BodyId id, std::uint32_t group, std::uint32_t mask) {
  erase_pairs_of(kept_, id);
  auto found = entries_.find(id);
  if (found == entries_.end() || found->second->role == Role::Static) return false;
  Entry& e = *found->second;
  unpark_for_input(e);
  e.description.collision_group = group;
  e.description.collision_mask = mask;
  parts_->world.removeRigidBody(e.body.get());
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e.body.get(), proxy_bits(group), proxy_bits(mask));
  quiet_ = -1;
  return true;
}

// A kinematic body's filter, in every world at the same boundary: the
// command joins its description (a world rebuilt later takes the filter
// in effect from there: collision_filter_before), and the body leaves the
// broadphase and comes back with it, as a dynamic body's does. Every parked
// island comes back first: a pair the new filter allows with a parked body
// is found at the next collide, as in a world that parks nothing.
bool TerritoryWorld::filter_kinematic(BodyId id, const FilterCommand& command) {
  auto found = entries_.find(id);
  if (found == entries_.end() || !found->second->description.kinematic) return false;
  Entry& e = *found->second;
  record_command(e.description.filter_commands, command);
  erase_pairs_of(kept_, id);
  if (parking_ && parts_->parking.parked_islands() > 0) {
    // As unpark_for_input, for every island: bodies and contacts back now,
    // so that the body's contacts with them end below as Bullet's do.
    parts_->parking.touch_all();
    parts_->parking.wake_touched();
    parts_->parking.restore_woken_contacts();
    sort_lists();
  }
  parts_->world.removeRigidBody(e.body.get());
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e.body.get(), proxy_bits(command.group),
                                proxy_bits(command.mask));
  quiet_ = -1;
  return true;
}

bool TerritoryWorld::add_body(const Body& body, const Vec3* home) {
  if (body.is_static) throw PartitionError("TerritoryWorld::add_body: static bodies cannot be added to a running scene");
  if (body.id > kMaxBodyId) throw PartitionError("TerritoryWorld: body id above kMaxBodyId");
  if (owner_of_origin(to_bt(home ? *home : body.position)) != id_) return false;
  if (entries_.count(body.id) || parts_->statics.is_static(body.id))
    throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": body " +
                         std::to_string(body.id) + " added, but that id is present");
  insert_dynamic(body, nullptr, true, id_);
  sort_lists();
  return true;
}

bool TerritoryWorld::remove_body(BodyId id) {
  if (!owns(id)) return false;
  unpark_for_input(*entries_.at(id));
  drop_joints(id, 0, true);
  erase_pairs_of(kept_, id);
  remove_entry(id);
  return true;
}

}  // namespace soda
