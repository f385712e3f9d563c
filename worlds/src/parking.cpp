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
constexpr int kParkedTopDownThreshold = 2;
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

Parking::Parking(ParkingHost& host, btDiscreteDynamicsWorld& world, btDbvtBroadphase& broadphase,
                 btCollisionDispatcher& dispatcher)
    : host_(host), world_(world), broadphase_(broadphase), dispatcher_(dispatcher) {}

Parking::~Parking() = default;

void DetachableWorld::compact_detached_bodies() {
  int w = 0;
  for (int i = 0; i < m_collisionObjects.size(); ++i) {
    btCollisionObject* o = m_collisionObjects[i];
    o->setWorldArrayIndex(o->getBroadphaseHandle() ? w : -1);
    if (o->getBroadphaseHandle()) m_collisionObjects[w++] = o;
  }
  m_collisionObjects.resize(w);
  w = 0;
  for (int i = 0; i < m_nonStaticRigidBodies.size(); ++i)
    if (m_nonStaticRigidBodies[i]->getBroadphaseHandle()) m_nonStaticRigidBodies[w++] = m_nonStaticRigidBodies[i];
  m_nonStaticRigidBodies.resize(w);
}

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
    const btBroadphaseProxy* proxy = b->getBroadphaseHandle();
    island.filters.push_back({proxy->m_collisionFilterGroup, proxy->m_collisionFilterMask});
    leaving_.push_back(b);
    btVector3 lo, hi;
    bullet_aabb(*b, lo, hi);
    island.leaves.push_back(tree_.insert(btDbvtVolume::FromMM(lo, hi), reinterpret_cast<void*>(slot)));
    const int leaves = tree_.m_leaves;
    if (leaves >= kRebuildFromLeaves && (leaves & (leaves - 1)) == 0) tree_.optimizeTopDown(kParkedTopDownThreshold);
  }
  ++parked_islands_;
  parked_bodies_ += static_cast<std::size_t>(n);
  return slot;
}

void Parking::add_contact(std::size_t slot, const btPersistentManifold& m) {
  Island& island = islands_[slot];
  island.manifolds.push_back(read_manifold_state(m));
  island.pair_objects.emplace_back(const_cast<btCollisionObject*>(m.getBody0()),
                                   const_cast<btCollisionObject*>(m.getBody1()));
}

void park_lone_settled_bodies(Parking& parking, CanonicalDynamicsWorld& world, btCollisionDispatcher& dispatcher,
                              btScalar h) {
  if (gDisableDeactivation) return;
  for (int i = 0; i < dispatcher.getNumManifolds(); ++i)
    if (dispatcher.getManifoldByIndexInternal(i)->getNumContacts() > 0) return;
  const std::vector<btRigidBody*> candidates = world.dynamic_bodies();
  for (btRigidBody* b : candidates)
    if (b->getBroadphaseHandle() && !world.jointed(b) && body_settled(*b, h)) {
      btCollisionObject* one[] = {b};
      parking.add_island(one, 1);
    }
  parking.finish_parking();
}

void park_settled_islands(Parking& parking, CanonicalDynamicsWorld& world, btCollisionDispatcher& dispatcher,
                          btScalar h) {
  if (gDisableDeactivation) return;
  const int islands = world.island_count();
  std::vector<int> slot_of(static_cast<std::size_t>(islands), -1);  // per island of the last stage
  bool any = false;
  for (int k = 0; k < islands; ++k) {
    const int n = world.island_size(k);
    btCollisionObject* const* bodies = world.island_bodies(k);
    bool park = n > 0;
    for (int j = 0; j < n && park; ++j) {
      const btRigidBody* b = btRigidBody::upcast(bodies[j]);
      park = b && b->getBroadphaseHandle() && !world.jointed(b) && body_settled(*b, h);
    }
    if (!park) continue;
    slot_of[static_cast<std::size_t>(k)] = static_cast<int>(parking.add_island(bodies, n));
    any = true;
  }
  if (!any) return;
  // Their contact state: every manifold with points is within one island
  // (or with a static body).
  for (int i = 0; i < dispatcher.getNumManifolds(); ++i) {
    const btPersistentManifold* m = dispatcher.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    const int tag = m->getBody0()->getIslandTag() >= 0 ? m->getBody0()->getIslandTag() : m->getBody1()->getIslandTag();
    if (tag < 0 || tag >= islands || slot_of[static_cast<std::size_t>(tag)] < 0) continue;
    parking.add_contact(static_cast<std::size_t>(slot_of[static_cast<std::size_t>(tag)]), *m);
  }
  parking.finish_parking();
}

void Parking::finish_parking() {
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
  host_.forget_detached_bodies();
  // Bullet's trees keep the shape the removed leaves gave them (removal never
  // rebalances): after parking most of a world (100,000 sleepers after the
  // first step), every moving proxy's update walked that shape. Rebuilt top
  // down; the trees' shapes decide only the order overlaps are found in.
  for (btDbvt& set : broadphase_.m_sets)
    if (static_cast<std::size_t>(set.m_leaves) * kRebuildAfterRemoving < leaving_.size())
      set.optimizeTopDown(kParkedTopDownThreshold);
  leaving_.clear();
}

void Parking::unpark_bodies(std::size_t slot) {
  Island& island = islands_[slot];
  for (btDbvtNode* leaf : island.leaves) tree_.remove(leaf);
  island.leaves.clear();
  for (std::size_t j = 0; j < island.bodies.size(); ++j) {
    btRigidBody* b = island.bodies[j];
    host_.return_body(b, island.filters[j].first, island.filters[j].second);
    world_.updateSingleAabb(b);  // as this step's AABB update (the body did not move)
  }
  island.parked = false;
  --parked_islands_;
  parked_bodies_ -= island.bodies.size();
  woken_.push_back(slot);
}

void Parking::touch(const btVector3& lo, const btVector3& hi) {
  if (parked_islands_ == 0) return;
  Collector collector;
  collector.hits = &hits_;
  tree_.collideTV(tree_.m_root, btDbvtVolume::FromMM(lo, hi), collector);
}

void Parking::touch_all() {
  for (std::size_t s = 0; s < islands_.size(); ++s)
    if (islands_[s].parked) hits_.push_back(s);
}

void Parking::wake_touched() {
  for (std::size_t s : hits_)
    if (islands_[s].parked) unpark_bodies(s);
  hits_.clear();
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
    island.filters.clear();
    island.manifolds.clear();
    island.pair_objects.clear();
    free_.push_back(slot);
  }
  woken_.clear();
}

void Parking::unpark_island(std::size_t slot) {
  if (slot >= islands_.size() || !islands_[slot].parked) throw std::logic_error("parking: no island parked there");
  unpark_bodies(slot);
  restore_woken_contacts();
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
