// TerritoryWorld, predict and exchange_ghosts (docs/partitioned-step.md):
// owned bodies predicted as Bullet's step does before collision detection,
// their halos, which neighbours get which ghosts and the contact state that
// travels with them; the ghosts received in their place.
#include <algorithm>
#include <span>
#include <string>

#include "safe_box.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

// Bit of cell c in a bitset over the map box's cells (false outside the
// box), as in interior_. Forced inline: predict asks it for every owned body.
[[gnu::always_inline]] inline bool interior_bit(const std::vector<std::uint64_t>& bits, const CellBox& box,
                                                const CellCoord& c) {
  if (!box.contains(c)) return false;
  const std::size_t i = box.index(c);
  return (bits[i / 64] >> (i % 64)) & 1;
}

}  // namespace

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
  if (parts_->replay.armed()) mark_clean();
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  parts_->statics.prepare();
  move_kinematic_bodies();
  outgoing_.clear();
  attachments_.clear();
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
    find_ghost_targets(e, cull);
  }
  if (!outgoing_.empty()) attach_kept_contacts();
}

// Every world holds every kinematic body (as every static) and moves it to
// its pose of the step's end, with the velocity of the move, before
// collision detection: the same bits in every world (bullet_bodies.h).
// integrate() writes them again after the solve, which writes the
// velocities of the kinematic bodies it touched back.
void TerritoryWorld::move_kinematic_bodies() {
  for (Entry* e : statics_)
    if (e->description.kinematic) write_kinematic_state(*e->body, e->description, settings_, steps_done_ + 1);
}

// The halo of an owned body (the AABB Bullet gives it for the step, which
// collide reuses) and the neighbours whose cells it overlaps: they get it as
// a ghost (Entry::sent_to, outgoing_).
void TerritoryWorld::find_ghost_targets(Entry& e, bool cull) {
  const btRigidBody& rb = *e.body;
  const std::vector<WorldId>& nbrs = neighbours();
  const UniformGrid& grid = map_.grid();
  const CellBox& box = map_.box();
  const std::span<const WorldId> owners = map_.owners();
  bullet_aabb(rb, e.halo_min, e.halo_max);
  e.sent_to.clear();
  const Vec3 lo = to_vec3(e.halo_min), hi = to_vec3(e.halo_max);
  // Border culling: still inside the block of owned cells it was found in
  // (false for a NaN or infinite halo, which the lookup below reports).
  if (cull && lo.x() >= e.safe_lo.x() && lo.y() >= e.safe_lo.y() && lo.z() >= e.safe_lo.z() &&
      hi.x() <= e.safe_hi.x() && hi.y() <= e.safe_hi.y() && hi.z() <= e.safe_hi.z()) {
    e.halo_owned_step = steps_done_;  // for migrate
    ++counters_.halos_culled;
    return;
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
    return;
  }
  parts_->statics.load(cells);  // a halo beyond the reach of the own cells: its statics
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

// Contact state kept here whose key body is a border body travels with its
// ghosts: live manifolds with points (held here at the last step) and values
// of the kept store, by (id0, id1).
void TerritoryWorld::attach_kept_contacts() {
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
  parts_->step_runs_ahead = speculative;
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
        if (!same_material(e->description, d)) {  // an input changed it at its owner
          e->description = d;
          apply_material(*e->body, d, to_bt(settings_.gravity));
        }
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

}  // namespace soda
