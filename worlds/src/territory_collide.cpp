// TerritoryWorld, collide: AABBs, pairs, and narrowphase of the pairs this
// world holds, each seeded with its contact state first when that state lives
// elsewhere (docs/partitioned-step.md, "collide").
//
// Rule H, the holder of a pair (computed identically by every world that has
// both bodies, from values every such world has):
//   static S + dynamic A:  owner(A);
//   dynamic A < B:         owner(A) if it has B, else owner(B) if it has A,
//                          else the owner of the cell holding the lower corner
//                          of the two halos' intersection (both halos overlap
//                          that cell, so its owner has both); nobody if the
//                          halos do not intersect.
// A world has a body if it owns it or the body's halo overlaps one of its
// cells (then it received the body as a ghost).
#include <algorithm>
#include <string>

#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>

#include "canonical_dynamics_world.h"
#include "pair_manifold.h"
#include "speculative_contact.h"
#include "territory_world_parts.h"

namespace soda {

BodyId TerritoryWorld::key_of(BodyId id0, BodyId id1) const {
  // Every world knows every static (held or not): any other body is dynamic.
  if (parts_->statics.is_static(id0)) return id1;
  if (parts_->statics.is_static(id1)) return id0;
  return id0;
}

bool TerritoryWorld::has(WorldId world, const Entry& e) const {
  return e.owner == world || std::binary_search(e.sent_to.begin(), e.sent_to.end(), world);
}

WorldId TerritoryWorld::holder_of(const Entry& a, const Entry& b, const void* pair_ptr) const {
  if (a.role == Role::Static) return b.role == Role::Static ? kNoWorld : b.owner;
  if (b.role == Role::Static) return a.owner;
  if (has(a.owner, b)) return a.owner;
  if (has(b.owner, a)) return b.owner;
  const auto& pair = *static_cast<const btBroadphasePair*>(pair_ptr);
  const btVector3& min0 = pair.m_pProxy0->m_aabbMin;
  const btVector3& max0 = pair.m_pProxy0->m_aabbMax;
  const btVector3& min1 = pair.m_pProxy1->m_aabbMin;
  const btVector3& max1 = pair.m_pProxy1->m_aabbMax;
  Vec3 corner;
  for (int i = 0; i < 3; ++i) {
    const btScalar lo = std::max(min0[i], min1[i]);
    if (lo > std::min(max0[i], max1[i])) return kNoWorld;
    corner[i] = double(lo);
  }
  return map_.owner_of(corner);
}

void TerritoryWorld::collide() {
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  btDiscreteDynamicsWorld& world = parts_->world;
  btDispatcherInfo& info = world.getDispatchInfo();
  info.m_timeStep = h;
  info.m_stepCount = 0;
  info.m_debugDraw = nullptr;
  world.getSolverInfo().m_timeStep = h;
  update_aabbs();
  wake_parked();  // parked islands an active body or ghost touches (territory_parking.cpp)
  parts_->speculative.clear();
  world.computeOverlappingPairs();
  remove_stale_pairs(parts_->broadphase, &parts_->dispatcher);
  parts_->parking.restore_woken_contacts();
  parts_->dispatcher.dispatchAllCollisionPairs(parts_->broadphase.getOverlappingPairCache(), info,
                                               &parts_->dispatcher);
  seeds_.clear();
}

// As btCollisionWorld::updateAabbs (every object), with the owned bodies'
// halos that predict computed the same way (updateSingleAabb).
void TerritoryWorld::update_aabbs() {
  btDiscreteDynamicsWorld& world = parts_->world;
  for (Entry* e : owned_) {
    if ((e->halo_max - e->halo_min).length2() < btScalar(1e12)) {
      parts_->broadphase.setAabb(e->body->getBroadphaseHandle(), e->halo_min, e->halo_max, &parts_->dispatcher);
    } else {
      e->body->setActivationState(DISABLE_SIMULATION);
    }
  }
  for (Entry* e : ghosts_) world.updateSingleAabb(e->body.get());
  for (Entry* e : statics_) world.updateSingleAabb(e->body.get());
}

// As btCollisionDispatcher::defaultNearCallback, for held pairs only.
void TerritoryWorld::near_callback(void* pair_ptr) {
  btBroadphasePair& pair = *static_cast<btBroadphasePair*>(pair_ptr);
  auto* obj0 = static_cast<btCollisionObject*>(pair.m_pProxy0->m_clientObject);
  auto* obj1 = static_cast<btCollisionObject*>(pair.m_pProxy1->m_clientObject);
  const Entry& a = entry_of(obj0);
  const Entry& b = entry_of(obj1);
  if (holder_of(a, b, pair_ptr) != id_) {
    // Invariant 3: a copy of a pair held elsewhere stays empty here.
    if (pair.m_algorithm) {
      btManifoldArray& ms = parts_->scratch;
      ms.resize(0);
      pair.m_algorithm->getAllContactManifolds(ms);
      for (int i = 0; i < ms.size(); ++i)
        if (ms[i]->getNumContacts() > 0) ms[i]->clearManifold();
    }
    return;
  }
  if (a.seed_step == steps_done_ && b.seed_step == steps_done_) {
    auto seed = seeds_.find(PairKey{a.id(), b.id()});
    if (seed != seeds_.end()) {
      seed_pair(pair_ptr, seed->second);
      ++counters_.manifolds_seeded;
    }
  }
  btCollisionDispatcher& dispatcher = parts_->dispatcher;
  if (!dispatcher.needsCollision(obj0, obj1)) return;
  btCollisionObjectWrapper w0(nullptr, obj0->getCollisionShape(), obj0, obj0->getWorldTransform(), -1, -1);
  btCollisionObjectWrapper w1(nullptr, obj1->getCollisionShape(), obj1, obj1->getWorldTransform(), -1, -1);
  if (!pair.m_algorithm) pair.m_algorithm = dispatcher.findAlgorithm(&w0, &w1, nullptr, BT_CONTACT_POINT_ALGORITHMS);
  if (!pair.m_algorithm) return;
  btManifoldResult result(&w0, &w1);
  pair.m_algorithm->processCollision(&w0, &w1, parts_->world.getDispatchInfo(), &result);
  // Fast bodies: as CanonicalDynamicsWorld::performDiscreteCollisionDetection,
  // for the pairs held here (docs/ccd.md).
  if (is_fast(*obj0) || is_fast(*obj1)) {
    btManifoldArray& ms = parts_->scratch;
    ms.resize(0);
    pair.m_algorithm->getAllContactManifolds(ms);
    if (ms.size() == 1 && add_speculative_contact(*ms[0])) parts_->speculative.push_back(ms[0]);
  }
}

// The pair's manifold takes the points of a value, in their order.
void TerritoryWorld::seed_pair(void* pair_ptr, const ManifoldState& state) {
  btBroadphasePair& pair = *static_cast<btBroadphasePair*>(pair_ptr);
  btPersistentManifold* m = nullptr;
  try {
    m = &pair_manifold(pair, parts_->dispatcher, parts_->world.getDispatchInfo());
  } catch (const std::logic_error& e) {
    throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": " + e.what());
  }
  if (static_cast<BodyId>(m->getBody0()->getUserIndex()) != state.id0 ||
      static_cast<BodyId>(m->getBody1()->getUserIndex()) != state.id1)
    throw std::logic_error("TerritoryWorld: manifold body order differs from the value's");
  write_manifold_points(state, *m);
}

}  // namespace soda
