#include "parking.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <unordered_set>

#include <BulletDynamics/Dynamics/btRigidBody.h>
#include <LinearMath/btTransformUtil.h>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "pair_cache.h"
#include "pair_manifold.h"
#include "settled.h"

namespace soda {
namespace {

// The parked tree is rebuilt top down whenever its leaf count reaches a
// power of two from this one on: bodies are parked in id order, mostly
// spatial order, and btDbvt::insert alone then builds a deep tree (the
// broadphase's case, canonical_dynamics_world.cpp), which made parking
// 100,000 sleepers walk hundreds of levels per insertion and every wake
// query too. O(N log N) in all. Threshold 2: a pure top-down split.
constexpr int kRebuildFromLeaves = 1024;
constexpr int kTopDownThreshold = 2;
// Bullet's broadphase trees are rebuilt after a batch removed more than this
// many times the leaves left in them.
constexpr std::size_t kRebuildAfterRemoving = 1;

struct Collector final : btDbvt::ICollide {
  std::vector<std::size_t>* hits = nullptr;
  void Process(const btDbvtNode* leaf) override {
    hits->push_back(static_cast<std::size_t>(reinterpret_cast<std::uintptr_t>(leaf->data)));
  }
};

}  // namespace

Parking::Parking(CanonicalDynamicsWorld& world, btDbvtBroadphase& broadphase, btCollisionDispatcher& dispatcher)
    : world_(world), broadphase_(broadphase), dispatcher_(dispatcher) {}

Parking::~Parking() = default;

std::size_t Parking::add_island(btCollisionObject* const* bodies, int n) {
  std::size_t slot;
  if (free_.empty()) {
    slot = islands_.size();
    islands_.emplace_back();
  } else {
    slot = free_.back();
    free_.pop_back();
  }
  Island& island = islands_[slot];
  island.parked = true;
  for (int j = 0; j < n; ++j) {
    btRigidBody* b = btRigidBody::upcast(bodies[j]);
    island.bodies.push_back(b);
    leaving_.push_back(b);
    btVector3 lo, hi;
    bullet_aabb(*b, lo, hi);
    island.leaves.push_back(tree_.insert(btDbvtVolume::FromMM(lo, hi), reinterpret_cast<void*>(slot)));
    const int leaves = tree_.m_leaves;
    if (leaves >= kRebuildFromLeaves && (leaves & (leaves - 1)) == 0) tree_.optimizeTopDown(kTopDownThreshold);
  }
  ++parked_islands_;
  parked_bodies_ += static_cast<std::size_t>(n);
  return slot;
}

void Parking::park_lone_settled(btScalar h) {
  if (gDisableDeactivation) return;
  for (int i = 0; i < dispatcher_.getNumManifolds(); ++i)
    if (dispatcher_.getManifoldByIndexInternal(i)->getNumContacts() > 0) return;
  leaving_.clear();
  const std::vector<btRigidBody*> candidates = world_.dynamic_bodies();
  for (btRigidBody* b : candidates)
    if (b->getBroadphaseHandle() && body_settled(*b, h) && within_contract(*b)) {
      btCollisionObject* one[] = {b};
      add_island(one, 1);
    }
  remove_leaving();
}

void Parking::park_settled(btScalar h) {
  if (gDisableDeactivation) return;
  const int islands = world_.island_count();
  island_state_.assign(static_cast<std::size_t>(islands), -1);
  leaving_.clear();
  for (int k = 0; k < islands; ++k) {
    const int n = world_.island_size(k);
    btCollisionObject* const* bodies = world_.island_bodies(k);
    bool park = n > 0;
    for (int j = 0; j < n && park; ++j) {
      const btRigidBody* b = btRigidBody::upcast(bodies[j]);
      park = b && b->getBroadphaseHandle() && body_settled(*b, h) && within_contract(*b);
    }
    if (!park) continue;
    island_state_[static_cast<std::size_t>(k)] = static_cast<int>(add_island(bodies, n));
  }
  if (leaving_.empty()) return;
  // Their contact state: every manifold with points is within one island
  // (or with a static body).
  for (int i = 0; i < dispatcher_.getNumManifolds(); ++i) {
    const btPersistentManifold* m = dispatcher_.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    const int tag = m->getBody0()->getIslandTag() >= 0 ? m->getBody0()->getIslandTag() : m->getBody1()->getIslandTag();
    if (tag < 0 || tag >= islands || island_state_[static_cast<std::size_t>(tag)] < 0) continue;
    Island& island = islands_[static_cast<std::size_t>(island_state_[static_cast<std::size_t>(tag)])];
    island.manifolds.push_back(read_manifold_state(*m));
    island.pair_objects.emplace_back(const_cast<btCollisionObject*>(m->getBody0()),
                                     const_cast<btCollisionObject*>(m->getBody1()));
  }

  remove_leaving();
}

void Parking::remove_leaving() {
  if (leaving_.empty()) return;
  // Out of the broadphase: their pairs in one sweep (freeing algorithms and
  // manifolds), then their proxies without Bullet's sweep of every pair per
  // proxy, then out of the world's lists in one pass.
  std::unordered_set<const btBroadphaseProxy*> proxies;
  proxies.reserve(leaving_.size());
  for (const btRigidBody* b : leaving_) proxies.insert(b->getBroadphaseHandle());
  auto& cache = static_cast<PairCache&>(*broadphase_.getOverlappingPairCache());
  btBroadphasePairArray& pairs = cache.getOverlappingPairArray();
  for (int i = 0; i < pairs.size();) {
    if (proxies.count(pairs[i].m_pProxy0) || proxies.count(pairs[i].m_pProxy1))
      cache.removeOverlappingPair(pairs[i].m_pProxy0, pairs[i].m_pProxy1, &dispatcher_);
    else
      ++i;
  }
  cache.set_proxy_sweeps(false);
  for (btRigidBody* b : leaving_) {
    broadphase_.destroyProxy(b->getBroadphaseHandle(), &dispatcher_);
    b->setBroadphaseHandle(nullptr);
  }
  cache.set_proxy_sweeps(true);
  world_.forget_detached_bodies();
  // Bullet's trees keep the shape the removed leaves gave them (removal never
  // rebalances): after parking most of a world (100,000 sleepers after the
  // first step), every moving proxy's update walked that shape. Rebuilt top
  // down; the trees' shapes decide only the order overlaps are found in.
  for (btDbvt& set : broadphase_.m_sets)
    if (static_cast<std::size_t>(set.m_leaves) * kRebuildAfterRemoving < leaving_.size())
      set.optimizeTopDown(kTopDownThreshold);
}

void Parking::unpark_bodies(std::size_t slot) {
  Island& island = islands_[slot];
  for (btDbvtNode* leaf : island.leaves) tree_.remove(leaf);
  island.leaves.clear();
  for (btRigidBody* b : island.bodies) {
    world_.add_body(b);
    world_.updateSingleAabb(b);  // as this step's updateAabbs (the body did not move)
  }
  island.parked = false;
  --parked_islands_;
  parked_bodies_ -= island.bodies.size();
  woken_.push_back(slot);
}

void Parking::wake_touched() {
  if (parked_islands_ == 0) return;
  std::vector<std::size_t> hits;
  if (gDisableDeactivation) {
    for (std::size_t s = 0; s < islands_.size(); ++s)
      if (islands_[s].parked) hits.push_back(s);
  } else {
    Collector collector;
    collector.hits = &hits;
    for (btRigidBody* b : world_.dynamic_bodies()) {
      if (!b->isActive()) continue;
      const btBroadphaseProxy* p = b->getBroadphaseHandle();
      tree_.collideTV(tree_.m_root, btDbvtVolume::FromMM(p->m_aabbMin, p->m_aabbMax), collector);
    }
  }
  for (std::size_t s : hits)
    if (islands_[s].parked) unpark_bodies(s);
}

void Parking::restore_woken_contacts() {
  if (woken_.empty()) return;
  btOverlappingPairCache* cache = broadphase_.getOverlappingPairCache();
  for (std::size_t slot : woken_) {
    Island& island = islands_[slot];
    for (std::size_t i = 0; i < island.manifolds.size(); ++i) {
      const ManifoldState& ms = island.manifolds[i];
      btCollisionObject* a = island.pair_objects[i].first;
      btCollisionObject* b = island.pair_objects[i].second;
      btBroadphasePair* pair = cache->findPair(a->getBroadphaseHandle(), b->getBroadphaseHandle());
      if (!pair) pair = cache->addOverlappingPair(a->getBroadphaseHandle(), b->getBroadphaseHandle());
      if (!pair) throw std::logic_error("parking: the pair cache refused a parked pair");
      write_manifold_points(ms, pair_manifold(*pair, dispatcher_, world_.getDispatchInfo()));
    }
    island.bodies.clear();
    island.manifolds.clear();
    island.pair_objects.clear();
    free_.push_back(slot);
  }
  woken_.clear();
}

void Parking::unpark_all() {
  if (parked_islands_ == 0) return;
  for (std::size_t s = 0; s < islands_.size(); ++s)
    if (islands_[s].parked) unpark_bodies(s);
  // A broadphase pass, as a snapshot restore does, then the manifolds.
  world_.updateAabbs();
  world_.btCollisionWorld::computeOverlappingPairs();
  remove_stale_pairs(broadphase_, &dispatcher_);
  restore_woken_contacts();
}

void Parking::append_contacts(std::vector<ManifoldState>& out) const {
  for (const Island& island : islands_)
    if (island.parked) out.insert(out.end(), island.manifolds.begin(), island.manifolds.end());
}

}  // namespace soda
