// TerritoryWorld: construction, predict, exchange_ghosts, readout.
#include <algorithm>
#include <cmath>
#include <map>
#include <span>
#include <sstream>
#include <string>

#include "canonical_dynamics_world.h"
#include "soda/worlds/bullet_allocator.h"
#include "soda/worlds/bullet_bodies.h"
#include "island_solver_settings.h"
#include "safe_box.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

Vec3 to_vec3(const btVector3& v) { return Vec3(double(v.x()), double(v.y()), double(v.z())); }

// Bit of cell c in a bitset over the map box's cells (false outside the
// box), as in interior_. Forced inline: predict asks it for every owned body.
[[gnu::always_inline]] inline bool interior_bit(const std::vector<std::uint64_t>& bits, const CellBox& box,
                                                const CellCoord& c) {
  if (!box.contains(c)) return false;
  const std::size_t i = box.index(c);
  return (bits[i / 64] >> (i % 64)) & 1;
}

}  // namespace

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
  for (const Body& b : scene.bodies) {
    if (b.id > kMaxBodyId) throw PartitionError("TerritoryWorld: body id above kMaxBodyId");
    if (b.is_static) {
      insert_static(b);
      continue;
    }
    // Home cell from the position as Bullet holds it (rounded to btScalar).
    if (owner_of_origin(to_bt(b.position)) != id_) continue;
    insert_dynamic(b, nullptr, true, id_);
  }
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

// parts_ goes before entries_ (member order), pairs first: linear in bodies.
TerritoryWorld::~TerritoryWorld() = default;

void TerritoryWorld::insert_static(const Body& b) {
  auto e = std::make_unique<Entry>();
  e->description = b;
  e->shape = make_collision_shape(b.shape);
  e->body = make_rigid_body(b, *e->shape);
  e->role = Role::Static;
  e->body->setUserPointer(e.get());
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e->body.get());
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
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, e->body.get());
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

// predict: what btDiscreteDynamicsWorld::stepSimulation does to every body
// before collision detection (applyGravity, predictUnconstraintMotion,
// createPredictiveContacts without CCD), for owned bodies only; then halos.
void TerritoryWorld::predict() {
  quiet_ = -1;
  halos_unknown_ = false;
  counters_ = TerritoryCounters{};
  coloured_before_ = parts_->solver.stats().coloured_islands;
  sort_lists();
  local_islands_.clear();
  if (replay_.before) mark_clean();
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  outgoing_.clear();
  attachments_.clear();
  const std::vector<WorldId>& nbrs = neighbours();
  const UniformGrid& grid = map_.grid();
  const CellBox& box = map_.box();
  const std::span<const WorldId> owners = map_.owners();
  const bool cull = border_culling();
  counters_.owned_bodies = parked_.size();  // parked bodies are not predicted (parking.h rule 1)
  counters_.parked_bodies = parked_.size();
  for (Entry* ep : owned_) {
    Entry& e = *ep;
    ++counters_.owned_bodies;
    btRigidBody& rb = *e.body;
    if (rb.isActive()) rb.applyGravity();
    rb.applyDamping(h);
    rb.predictIntegratedTransform(h, rb.getInterpolationWorldTransform());
    rb.setHitFraction(btScalar(1));
    // Halo: the AABB Bullet gives this body for the step (collide reuses it).
    bullet_aabb(rb, e.halo_min, e.halo_max);
    e.sent_to.clear();
    const Vec3 lo = to_vec3(e.halo_min), hi = to_vec3(e.halo_max);
    // Border culling: still inside the block of owned cells it was found in
    // (false for a NaN or infinite halo, which the lookup below reports).
    if (cull && lo.x() >= e.safe_lo.x() && lo.y() >= e.safe_lo.y() && lo.z() >= e.safe_lo.z() &&
        hi.x() <= e.safe_hi.x() && hi.y() <= e.safe_hi.y() && hi.z() <= e.safe_hi.z()) {
      e.halo_owned_step = steps_done_;  // for migrate
      ++counters_.halos_culled;
      continue;
    }
    CellBox cells;
    try {
      cells = grid.cells_overlapping(lo, hi);  // checks the halo is finite: no second check here
    } catch (const GridError&) {
      if (lo.allFinite() && hi.allFinite()) throw;
      throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": body " +
                           std::to_string(e.id()) + " has a non-finite AABB");
    }
    // No border body: the halo's cells (at most 3 along each axis) lie in the
    // 1-ring of their middle cell, an interior cell (so all are owned here).
    const CellCoord mid{cells.lo.x + (cells.hi.x - cells.lo.x) / 2, cells.lo.y + (cells.hi.y - cells.lo.y) / 2,
                        cells.lo.z + (cells.hi.z - cells.lo.z) / 2};
    if (cells.hi.x - cells.lo.x <= 2 && cells.hi.y - cells.lo.y <= 2 && cells.hi.z - cells.lo.z <= 2 &&
        interior_bit(interior_, box, mid)) {
      e.halo_owned_step = steps_done_;  // for migrate
      set_safe_box(e, grid, mid);
      continue;
    }
    // Owners read straight from the map's array when the cells are in its box.
    const bool in_box = box.contains(cells.lo) && box.contains(cells.hi);
    for (int x = cells.lo.x; x <= cells.hi.x; ++x)
      for (int y = cells.lo.y; y <= cells.hi.y; ++y) {
        std::size_t i = in_box ? box.index(CellCoord{x, y, cells.lo.z}) : 0;  // z runs fastest
        for (int z = cells.lo.z; z <= cells.hi.z; ++z, ++i) {
          const WorldId w = in_box ? owners[i] : map_.owner(CellCoord{x, y, z});
          if (w == id_ || std::find(e.sent_to.begin(), e.sent_to.end(), w) != e.sent_to.end()) continue;
          if (!std::binary_search(nbrs.begin(), nbrs.end(), w))
            throw PartitionError(beyond_reach(id_, steps_done_, e.id(), double(rb.getLinearVelocity().length()),
                                              "its halo overlaps", CellCoord{x, y, z}, w, map_));
          e.sent_to.push_back(w);
        }
      }
    std::sort(e.sent_to.begin(), e.sent_to.end());
    if (!e.sent_to.empty()) {
      ++counters_.border_bodies;
      for (WorldId w : e.sent_to) outgoing_[w].push_back(&e);
    }
  }
  if (outgoing_.empty()) return;
  // Contact state kept here whose key body is a border body travels with its
  // ghosts: live manifolds with points (held here at the last step) ...
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    const Entry& a = entry_of(m->getBody0());
    const Entry& k = a.role == Role::Static ? entry_of(m->getBody1()) : a;
    if (k.role == Role::Owned && !k.sent_to.empty()) attachments_[k.id()].push_back(read_manifold_state(*m));
  }
  // ... and values of the kept store.
  for (const auto& [pair, state] : kept_) {
    const BodyId key = key_of(pair.first, pair.second);
    auto it = entries_.find(key);
    if (it != entries_.end() && it->second->role == Role::Owned && !it->second->sent_to.empty())
      attachments_[key].push_back(state);
  }
  for (auto& [key, list] : attachments_)
    std::sort(list.begin(), list.end(), [](const ManifoldState& a, const ManifoldState& b) {
      return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
    });
  for (const auto& [w, list] : outgoing_) {
    counters_.ghosts_sent += list.size();
    for (const Entry* e : list) {
      auto a = attachments_.find(e->id());
      if (a != attachments_.end()) counters_.manifolds_attached += a->second.size();
    }
  }
}

BodyRecord TerritoryWorld::record_of(const Entry& e) const {
  BodyRecord r;
  r.body.description = e.description;
  r.body.state = read_dynamic_state(*e.body);
  const btVector3& f = e.body->getTotalForce();
  const btVector3& t = e.body->getTotalTorque();
  for (int i = 0; i < 3; ++i) r.total_force[i] = f[i], r.total_torque[i] = t[i];
  return r;
}

bool TerritoryWorld::sends_ghosts_to(WorldId neighbour) const {
  auto it = outgoing_.find(neighbour);
  return it != outgoing_.end() && !it->second.empty();
}

GhostBatch TerritoryWorld::ghost_batch_for(WorldId neighbour) const {
  GhostBatch batch;
  auto it = outgoing_.find(neighbour);
  if (it == outgoing_.end()) return batch;
  batch.ghosts.reserve(it->second.size());
  for (const Entry* e : it->second) {
    batch.ghosts.push_back(GhostRecord{record_of(*e), e->sent_to});
    auto a = attachments_.find(e->id());
    if (a != attachments_.end())
      batch.kept_manifolds.insert(batch.kept_manifolds.end(), a->second.begin(), a->second.end());
  }
  std::sort(batch.kept_manifolds.begin(), batch.kept_manifolds.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
  });
  return batch;
}

void TerritoryWorld::apply_ghosts(const std::vector<std::pair<WorldId, GhostBatch>>& batches, bool speculative) {
  for (Entry* e : ghosts_) e->refreshed = false;
  seeds_ = kept_;
  ghost_senders_.clear();
  for (const auto& [from, batch] : batches) {
    if (!batch.ghosts.empty()) ghost_senders_.push_back(from);
    counters_.ghosts_received += batch.ghosts.size();
    for (const GhostRecord& g : batch.ghosts) {
      const Body& d = g.record.body.description;
      auto it = entries_.find(d.id);
      Entry* e = nullptr;
      if (it == entries_.end()) {
        e = &insert_dynamic(d, &g.record.body.state, false, from);
      } else if (it->second->role == Role::Ghost) {
        e = it->second.get();
        if (e->refreshed && speculative) continue;
        if (e->refreshed)
          throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                               ": ghost of body " + std::to_string(d.id) + " received from worlds " +
                               std::to_string(e->owner) + " and " + std::to_string(from));
        write_dynamic_state(*e->body, g.record.body.state);
        e->owner = from;
      } else if (speculative) {
        continue;
      } else {
        throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                             ": world " + std::to_string(from) + " sent a ghost of body " + std::to_string(d.id) +
                             ", which this world owns (two owners)");
      }
      e->sent_to = g.sent_to;
      e->refreshed = true;
    }
    for (const ManifoldState& m : batch.kept_manifolds)
      if (!seeds_.emplace(PairKey{m.id0, m.id1}, m).second)
        throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                             ": two kept manifolds for pair " + std::to_string(m.id0) + "-" + std::to_string(m.id1));
  }
  std::vector<BodyId> stale;
  for (const Entry* e : ghosts_)
    if (!e->refreshed) stale.push_back(e->id());
  for (BodyId id : stale) remove_entry(id);
  // Mark the bodies of seeded pairs: the near callback looks a pair up in
  // seeds_ only if both its bodies are marked.
  for (const auto& [pair, state] : seeds_)
    for (BodyId id : {pair.first, pair.second}) {
      auto it = entries_.find(id);
      if (it != entries_.end()) it->second->seed_step = steps_done_;
    }
  std::sort(ghost_senders_.begin(), ghost_senders_.end());
  counters_.ghosts = ghost_count();
}

bool TerritoryWorld::received_ghosts_from(WorldId neighbour) const {
  return std::binary_search(ghost_senders_.begin(), ghost_senders_.end(), neighbour);
}

// --- readout -----------------------------------------------------------------

std::vector<BodyState> TerritoryWorld::owned_states() const {
  std::vector<BodyState> out;
  for (const Entry* e : all_owned_by_id()) out.push_back(read_body_state(*e->body));
  return out;
}

std::vector<BodyState> TerritoryWorld::static_states() const {
  std::vector<BodyState> out;
  for (const Entry* e : statics_) out.push_back(read_body_state(*e->body));
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
std::size_t TerritoryWorld::static_count() const { return statics_.size(); }
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
