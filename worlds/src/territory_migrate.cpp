// TerritoryWorld, integrate and migrate.
//
// migrate keeps invariant 4 (contact state is never lost) when a body leaves
// this world's Bullet world, which destroys its pairs and their manifolds:
// first every live manifold with points on it is exported — to the migrant's
// payload if the migrant is the pair's key body, to this world's kept store if
// the key body stays owned here, nowhere if the key body is a ghost (its owner
// got the state from the border island). A body arriving here that was a
// ghost is exported the same way before its ghost is replaced.
#include <algorithm>
#include <set>
#include <string>

#include "speculative_contact.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

bool by_pair(const ManifoldState& a, const ManifoldState& b) {
  return std::make_pair(a.id0, a.id1) < std::make_pair(b.id0, b.id1);
}

}  // namespace

// As btDiscreteDynamicsWorld::integrateTransforms (CCD off) and
// updateActivationState, for owned bodies; then clearForces.
void TerritoryWorld::integrate() {
  counters_.coloured_islands = parts_->solver.stats().coloured_islands - coloured_before_;
  counters_.solver_threads = parts_->solver.stats().threads_max;
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  // The step's speculative points end with its solve (docs/ccd.md); results
  // of border islands do not keep them (apply_island_result).
  for (btPersistentManifold* m : parts_->speculative) clear_speculative_contact(*m);
  parts_->speculative.clear();
  for (Entry* e : owned_) {
    btRigidBody& body = *e->body;
    body.setHitFraction(btScalar(1));
    if (body.isActive() && !body.isStaticOrKinematicObject()) {
      btTransform predicted;
      body.predictIntegratedTransform(h, predicted);
      body.proceedToTransform(predicted);
    }
  }
  for (Entry* e : owned_) {
    btRigidBody& body = *e->body;
    body.updateDeactivation(h);
    if (body.wantsSleeping()) {
      if (body.getActivationState() == ACTIVE_TAG) body.setActivationState(WANTS_DEACTIVATION);
      if (body.getActivationState() == ISLAND_SLEEPING) {
        body.setAngularVelocity(btVector3(0, 0, 0));
        body.setLinearVelocity(btVector3(0, 0, 0));
      }
    } else if (body.getActivationState() != DISABLE_DEACTIVATION) {
      body.setActivationState(ACTIVE_TAG);
    }
    body.clearForces();
  }
  if (parts_->replay.armed()) {
    if (!parts_->replay.mid_step()) parts_->replay.finish(id_, steps_done_);
    parts_->replay.clear();
  }
  move_kinematic_bodies();
  park_settled_islands();
  counters_.parked_bodies = parked_.size();
}

void TerritoryWorld::export_manifolds_involving(const std::vector<const Entry*>& leaving,
                                                std::map<BodyId, MigrantBatch*>* payload_by_key) {
  if (leaving.empty()) return;
  std::set<const btCollisionObject*> gone;
  for (const Entry* e : leaving) gone.insert(e->body.get());
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    if (!gone.count(m->getBody0()) && !gone.count(m->getBody1())) continue;
    ManifoldState state = read_manifold_state(*m);
    const BodyId key = key_of(state.id0, state.id1);
    if (payload_by_key) {
      auto p = payload_by_key->find(key);
      if (p != payload_by_key->end()) {
        p->second->migrants.front().kept_manifolds.push_back(std::move(state));
        continue;
      }
    }
    const Entry& k = *entries_.at(key);
    if (k.role == Role::Owned && !gone.count(k.body.get())) {
      const PairKey pk{state.id0, state.id1};
      kept_[pk] = std::move(state);
    }
  }
}

std::vector<std::pair<WorldId, MigrantBatch>> TerritoryWorld::migrate() {
  const std::vector<WorldId>& nbrs = neighbours();
  std::vector<const Entry*> leaving;
  std::map<BodyId, WorldId> destination;
  sort_lists();
  for (const Entry* e : owned_) {
    const BodyId id = e->id();
    // An origin inside a halo whose cells are all owned here lies in one of
    // them (cell_of is monotone on every axis): no owner lookup needed.
    const bool jointed = !anchor_.empty() && anchor_.count(id) != 0;
    if (e->halo_owned_step == steps_done_ && !jointed) {
      const btVector3& o = e->body->getWorldTransform().getOrigin();
      if (e->halo_min.x() <= o.x() && o.x() <= e->halo_max.x() && e->halo_min.y() <= o.y() &&
          o.y() <= e->halo_max.y() && e->halo_min.z() <= o.z() && o.z() <= e->halo_max.z())
        continue;
    }
    const WorldId w = jointed ? home_owner(*e) : owner_of_origin(*e);
    if (w == id_) continue;
    if (!std::binary_search(nbrs.begin(), nbrs.end(), w)) {
      const btVector3& o = e->body->getWorldTransform().getOrigin();
      throw PartitionError(beyond_reach(id_, steps_done_, id, double(e->body->getLinearVelocity().length()),
                                        "moved into", map_.grid().cell_of(Vec3(double(o.x()), double(o.y()), double(o.z()))),
                                        w, map_));
    }
    leaving.push_back(e);
    destination[id] = w;
  }
  // One single-migrant batch per leaving body first (payload by key), merged
  // into one batch per neighbour below.
  std::map<BodyId, MigrantBatch> single;
  std::map<BodyId, MigrantBatch*> payload_by_key;
  for (const Entry* e : leaving) {
    MigrantBatch& b = single[e->id()];
    b.migrants.push_back(Migrant{BodySnapshot{e->description, read_dynamic_state(*e->body)}, {}});
    payload_by_key[e->id()] = &b;
  }
  export_manifolds_involving(leaving, &payload_by_key);
  for (auto it = kept_.begin(); it != kept_.end();) {
    auto p = payload_by_key.find(key_of(it->first.first, it->first.second));
    if (p == payload_by_key.end()) {
      ++it;
      continue;
    }
    p->second->migrants.front().kept_manifolds.push_back(std::move(it->second));
    it = kept_.erase(it);
  }
  std::map<WorldId, MigrantBatch> out;
  for (WorldId w : nbrs) out[w];
  for (auto& [id, b] : single) {
    std::sort(b.migrants.front().kept_manifolds.begin(), b.migrants.front().kept_manifolds.end(), by_pair);
    out[destination.at(id)].migrants.push_back(std::move(b.migrants.front()));
  }
  if (!joints_.empty()) export_joints(destination, out);
  for (const Entry* e : leaving) remove_entry(e->id());
  counters_.migrations_out = leaving.size();
  return {out.begin(), out.end()};
}

void TerritoryWorld::absorb_migrants(const std::vector<std::pair<WorldId, MigrantBatch>>& batches) {
  std::vector<const Entry*> ghosts;
  for (const auto& [from, batch] : batches)
    for (const Migrant& m : batch.migrants) {
      auto it = entries_.find(m.body.description.id);
      if (it == entries_.end()) continue;
      if (it->second->role != Role::Ghost)
        throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                             ": world " + std::to_string(from) + " hands over body " +
                             std::to_string(m.body.description.id) + ", which this world already owns");
      ghosts.push_back(it->second.get());
    }
  export_manifolds_involving(ghosts, nullptr);
  for (const Entry* g : ghosts) remove_entry(g->id());
  for (const auto& [from, batch] : batches)
    for (const Migrant& m : batch.migrants) {
      insert_dynamic(m.body.description, &m.body.state, true, id_);
      for (const ManifoldState& s : m.kept_manifolds)
        if (!kept_.emplace(PairKey{s.id0, s.id1}, s).second)
          throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                               ": kept manifold " + std::to_string(s.id0) + "-" + std::to_string(s.id1) +
                               " arrives twice");
      ++counters_.migrations_in;
    }
  absorb_joints(batches);
  contacts_kept_elsewhere_ = false;  // from now on held here live, or by no one
  ++steps_done_;
}

}  // namespace soda
