// TerritoryWorld: construction, body lists, readout (predict and
// exchange_ghosts: territory_predict.cpp).
#include <algorithm>
#include <cmath>
#include <map>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>

#include "canonical_dynamics_world.h"
#include "soda/scene/kinematic_command.h"
#include "soda/worlds/bullet_allocator.h"
#include "soda/worlds/bullet_bodies.h"
#include "island_solver_settings.h"
#include "safe_box.h"
#include "territory_world_parts.h"

namespace soda {

std::string beyond_reach(WorldId world, std::int64_t step, BodyId body, double speed, const char* what,
                         const CellCoord& cell, WorldId other, const TerritoryMap& map) {
  std::ostringstream msg;
  msg << "world " << world << ", step " << step << ": body " << body << " moves at " << speed << " m/s and "
      << what << " cell " << to_string(cell) << " of world " << other
      << ", which is not a neighbour: this run's neighbours reach " << map.reach() << " cell(s) of "
      << map.grid().cell_size() << " m, sized for a slower scene; set the reach speed "
      << "(RuntimeOptions::reach_speed, soda run --reach-speed) to at least " << std::ceil(speed * 1.25)
      << " m/s (docs/partitioned-step.md, \"Reach beyond adjacent cells\")";
  return msg.str();
}

TerritoryWorld::TerritoryWorld(const Scene& scene, WorldId id, TerritoryMap map)
    : id_(id), map_(std::move(map)), settings_(scene.settings) {
  init_world();
  std::vector<const Body*> dynamic;
  std::vector<Body> fixed;
  for (const Body& b : scene.bodies) {
    if (b.id > kMaxBodyId) throw PartitionError("TerritoryWorld: body id above kMaxBodyId");
    if (b.kinematic)
      insert_static(b);
    else if (b.is_static)
      fixed.push_back(b);
    else
      dynamic.push_back(&b);
  }
  parts_->statics.init(std::make_shared<const StaticCatalog>(std::move(fixed)));
  std::vector<JointSnapshot> joints;
  joints.reserve(scene.joints.size());
  for (const Joint& j : scene.joints) joints.push_back(JointSnapshot{j, false});
  insert_owned_and_joints(dynamic, std::vector<const BodyDynamicState*>(dynamic.size(), nullptr), joints);
  init_interior();
}

void TerritoryWorld::init_world(const TerritoryWorld* share_pools_of) {
  if (id_ < 0 || id_ >= map_.world_count())
    throw PartitionError("TerritoryWorld: world id " + std::to_string(id_) + " outside the map's " +
                         std::to_string(map_.world_count()) + " worlds");
  install_bullet_allocator();
  parts_ = std::make_unique<Parts>(this, share_pools_of ? share_pools_of->parts_->config : nullptr);
  if (share_pools_of) parts_->solver.set_pool(share_pools_of->parts_->solver.pool());
  parts_->world.setGravity(to_bt(settings_.gravity));
  configure_canonical_solver(parts_->world.getSolverInfo(), settings_);
}

// Interior cells: owned here, and so are their 26 neighbours. A body whose
// halo stays within the 1-ring of an interior cell is no border body.
void TerritoryWorld::init_interior() {
  const CellBox& box = map_.box();
  interior_.assign(static_cast<std::size_t>((box.count() + 63) / 64), 0);
  for (const CellCoord& c : map_.cells_of(id_)) {
    bool inside = true;
    for (int dx = -1; dx <= 1 && inside; ++dx)
      for (int dy = -1; dy <= 1 && inside; ++dy)
        for (int dz = -1; dz <= 1 && inside; ++dz)
          inside = map_.owner(CellCoord{c.x + dx, c.y + dy, c.z + dz}) == id_;
    if (inside) {
      const std::size_t i = box.index(c);
      interior_[i / 64] |= std::uint64_t{1} << (i % 64);
    }
  }
  sort_lists();
}

void TerritoryWorld::sort_lists() {
  if (lists_sorted_) return;
  // Lists only grow at the back (erase keeps the order), so each is a sorted
  // prefix plus a short tail: sort the tail and merge, O(n + m log m) rather
  // than a full sort every step (callgrind: the full sort was ~3 % of a
  // 2-territory falling-cubes step).
  auto by_id = [](const Entry* a, const Entry* b) { return a->id() < b->id(); };
  for (std::vector<Entry*>* list : {&owned_, &ghosts_, &statics_}) {
    const auto tail = std::is_sorted_until(list->begin(), list->end(), by_id);
    std::sort(tail, list->end(), by_id);
    std::inplace_merge(list->begin(), tail, list->end(), by_id);
  }
  lists_sorted_ = true;
}

// parts_ goes before entries_ (member order), pairs first: linear in bodies;
// the joints leave the Bullet world before anything is destroyed.
TerritoryWorld::~TerritoryWorld() {
  if (parts_)
    for (const auto& [id, j] : joints_) parts_->world.removeConstraint(j->constraint.get());
}

void TerritoryWorld::insert_static(const Body& b) {
  auto e = std::make_unique<Entry>();
  e->description = b;
  e->shape = make_collision_shape(b.shape);
  e->body = make_rigid_body(b, *e->shape);
  // A kinematic body at its pose of this step (a pure function of the step:
  // a world rebuilt for a rollback needs nothing else).
  if (b.kinematic) write_kinematic_state(*e->body, b, settings_, steps_done_);
  e->role = Role::Static;
  e->body->setUserPointer(e.get());
  const auto [group, mask] = collision_filter_before(b, steps_done_, settings_.substeps);
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e->body.get(), proxy_bits(group), proxy_bits(mask));
  Entry* raw = e.get();
  if (!entries_.emplace(b.id, std::move(e)).second)
    throw PartitionError("TerritoryWorld: duplicate body id " + std::to_string(b.id));
  statics_.push_back(raw);
  lists_sorted_ = false;
}

TerritoryWorld::Entry& TerritoryWorld::insert_dynamic(const Body& description, const BodyDynamicState* state,
                                                      bool owned, WorldId owner) {
  quiet_ = -1;
  halos_unknown_ = halos_unknown_ || owned;
  auto e = std::make_unique<Entry>();
  e->description = description;
  e->shape = make_collision_shape(description.shape);
  e->body = state ? make_body_from_state(description, *e->shape, *state) : make_rigid_body(description, *e->shape);
  e->role = owned ? Role::Owned : Role::Ghost;
  e->owner = owner;
  e->body->setUserPointer(e.get());
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e->body.get(),
                                proxy_bits(description.collision_group), proxy_bits(description.collision_mask));
  if (state) {
    // After insertion: addRigidBody leaves a dynamic body's state alone, but
    // the construction made it ACTIVE_TAG.
    e->body->forceActivationState(state->activation_state);
    e->body->setDeactivationTime(state->deactivation_time);
  }
  Entry& ref = *e;
  if (!entries_.emplace(description.id, std::move(e)).second)
    throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": body " +
                         std::to_string(description.id) + " inserted twice");
  (owned ? owned_ : ghosts_).push_back(&ref);
  lists_sorted_ = false;
  return ref;
}

void TerritoryWorld::remove_entry(BodyId id) {
  quiet_ = -1;
  auto it = entries_.find(id);
  if (it == entries_.end()) throw std::logic_error("TerritoryWorld: removing an unknown body");
  Entry* e = it->second.get();
  if (e->parked) throw std::logic_error("TerritoryWorld: removing a parked body");
  std::vector<Entry*>& list = e->role == Role::Owned ? owned_ : (e->role == Role::Ghost ? ghosts_ : statics_);
  list.erase(std::find(list.begin(), list.end(), e));  // keeps the order
  parts_->world.removeRigidBody(e->body.get());
  entries_.erase(it);
}

WorldId TerritoryWorld::owner_of_origin(const Entry& e) const {
  return owner_of_origin(e.body->getWorldTransform().getOrigin());
}

WorldId TerritoryWorld::owner_of_origin(const btVector3& origin) const { return map_.owner_of(to_vec3(origin)); }

bool TerritoryWorld::owns(BodyId id) const {
  auto it = entries_.find(id);
  return it != entries_.end() && it->second->role == Role::Owned;
}

void TerritoryWorld::set_solver_pool(std::shared_ptr<SolverPool> pool) { parts_->solver.set_pool(std::move(pool)); }

std::shared_ptr<SolverPool> TerritoryWorld::solver_pool() const { return parts_->solver.pool(); }

const std::vector<WorldId>& TerritoryWorld::neighbours() const { return map_.neighbours(id_); }

// --- readout -----------------------------------------------------------------

std::vector<BodyState> TerritoryWorld::owned_states() const {
  std::vector<BodyState> out;
  for (const Entry* e : all_owned_by_id()) out.push_back(read_body_state(*e->body));
  return out;
}

std::vector<BodyState> TerritoryWorld::static_states() const {
  std::vector<BodyState> out;
  const StaticCatalog& catalog = *parts_->statics.catalog;
  for (std::size_t i = 0; i < catalog.size(); ++i) {  // as read_body_state reads a held one
    const BodyDynamicState& d = catalog.state(i);
    BodyState& b = out.emplace_back();
    b.id = catalog.body(i).id;
    std::copy(std::begin(d.basis), std::end(d.basis), b.basis);
    std::copy(std::begin(d.origin), std::end(d.origin), b.origin);
    std::copy(std::begin(d.linear_velocity), std::end(d.linear_velocity), b.linear_velocity);
    std::copy(std::begin(d.angular_velocity), std::end(d.angular_velocity), b.angular_velocity);
    b.activation_state = d.activation_state;
  }
  for (const Entry* e : statics_)
    if (e->description.kinematic) out.push_back(read_body_state(*e->body));
  std::sort(out.begin(), out.end(), [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  return out;
}

std::vector<BodyId> TerritoryWorld::owned_ids() const {
  std::vector<BodyId> out;
  for (const Entry* e : all_owned_by_id()) out.push_back(e->id());
  return out;
}

std::size_t TerritoryWorld::owned_count() const { return owned_.size() + parked_.size(); }
std::size_t TerritoryWorld::ghost_count() const { return ghosts_.size(); }
std::size_t TerritoryWorld::static_count() const {
  return parts_->statics.catalog->size() + statics_.size() - parts_->statics.held_count;
}
std::size_t TerritoryWorld::held_static_count() const { return statics_.size(); }
std::size_t TerritoryWorld::bullet_object_count() const {
  return static_cast<std::size_t>(parts_->world.getNumCollisionObjects());
}

std::size_t TerritoryWorld::sleeping_count() const {
  std::size_t n = parked_.size();  // settled: asleep
  for (const Entry* e : owned_)
    if (e->body->getActivationState() == ISLAND_SLEEPING) ++n;
  return n;
}

std::vector<std::pair<BodyId, BodyId>> TerritoryWorld::held_contact_pairs() const {
  std::vector<std::pair<BodyId, BodyId>> out;
  const btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = const_cast<btDispatcher&>(d).getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    out.emplace_back(static_cast<BodyId>(m->getBody0()->getUserIndex()),
                     static_cast<BodyId>(m->getBody1()->getUserIndex()));
  }
  std::vector<ManifoldState> parked;  // held here, out of the world
  parts_->parking.append_contacts(parked);
  for (const ManifoldState& m : parked) out.emplace_back(m.id0, m.id1);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<ManifoldState> TerritoryWorld::kept_contact_state() const {
  std::vector<ManifoldState> out;
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() > 0) out.push_back(read_manifold_state(*m));
  }
  for (const auto& [pair, state] : kept_) out.push_back(state);
  parts_->parking.append_contacts(out);
  std::sort(out.begin(), out.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
  });
  return out;
}

}  // namespace soda
