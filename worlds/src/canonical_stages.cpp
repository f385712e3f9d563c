// CanonicalDynamicsWorld: the per-body and per-pair stages of the step,
// shared on the solver pool's threads above a size (parallel_stages.h).
// Each is Bullet's own loop with the items' order left free; the rest of
// each stage stays on the stepping thread in Bullet's order.
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletCollision/CollisionDispatch/btCollisionDispatcher.h>

#include <algorithm>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "parallel_stages.h"
#include "soda/worlds/solver_pool.h"

namespace soda {
namespace {

// As btCollisionWorld::updateSingleAabb: a moving object's AABB above this
// squared size disables it (Bullet's "something went wrong" guard).
constexpr btScalar kMaxAabbLength2 = btScalar(1e12);

bool is_box(const btCollisionObject* o) {
  return o->getCollisionShape()->getShapeType() == BOX_SHAPE_PROXYTYPE;
}

// As btCollisionDispatcher::defaultNearCallback once the pair's algorithm
// exists.
void collide_pair(btBroadphasePair& pair, const btDispatcherInfo& info) {
  auto* obj0 = static_cast<btCollisionObject*>(pair.m_pProxy0->m_clientObject);
  auto* obj1 = static_cast<btCollisionObject*>(pair.m_pProxy1->m_clientObject);
  btCollisionObjectWrapper w0(nullptr, obj0->getCollisionShape(), obj0, obj0->getWorldTransform(), -1, -1);
  btCollisionObjectWrapper w1(nullptr, obj1->getCollisionShape(), obj1, obj1->getWorldTransform(), -1, -1);
  btManifoldResult result(&w0, &w1);
  pair.m_algorithm->processCollision(&w0, &w1, info, &result);
}

}  // namespace

SolverPool* CanonicalDynamicsWorld::stage_pool() const {
  SolverPool* pool = solver_->pool().get();
  return pool && pool->threads() > 1 ? pool : nullptr;
}

void CanonicalDynamicsWorld::note_stage_threads(int threads) {
  stats_.stage_threads = std::max(stats_.stage_threads, threads);
}

// As btDiscreteDynamicsWorld::predictUnconstraintMotion: per body.
void CanonicalDynamicsWorld::predictUnconstraintMotion(btScalar time_step) {
  stats_.stage_threads = 1;
  btRigidBody** bodies = m_nonStaticRigidBodies.size() ? &m_nonStaticRigidBodies[0] : nullptr;
  note_stage_threads(run_in_chunks(stage_pool(), m_nonStaticRigidBodies.size(), kParallelMinBodies, kBodiesPerTask,
                                   [&](int begin, int end) {
                                     for (int i = begin; i < end; ++i) {
                                       btRigidBody* body = bodies[i];
                                       if (body->isStaticOrKinematicObject()) continue;
                                       body->applyDamping(time_step);
                                       body->predictIntegratedTransform(time_step,
                                                                        body->getInterpolationWorldTransform());
                                     }
                                   }));
}

// As btCollisionWorld::updateAabbs: the AABBs (bullet_aabb, per object) in
// parallel, then the broadphase on this thread in object order.
void CanonicalDynamicsWorld::updateAabbs() {
  const int n = m_collisionObjects.size();
  SolverPool* pool = stage_pool();
  if (!pool || n < kParallelMinBodies || !getDispatchInfo().m_useContinuous) {
    btCollisionWorld::updateAabbs();
    return;
  }
  aabbs_.resize(static_cast<std::size_t>(n));
  note_stage_threads(run_in_chunks(pool, n, kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const btCollisionObject* o = m_collisionObjects[i];
      if (m_forceUpdateAllAabbs || o->isActive()) bullet_aabb(*o, aabbs_[i].min, aabbs_[i].max);
    }
  }));
  for (int i = 0; i < n; ++i) {
    btCollisionObject* o = m_collisionObjects[i];
    if (!(m_forceUpdateAllAabbs || o->isActive())) continue;
    const Aabb& box = aabbs_[static_cast<std::size_t>(i)];
    if (o->isStaticObject() || (box.max - box.min).length2() < kMaxAabbLength2) {
      broadphase_->setAabb(o->getBroadphaseHandle(), box.min, box.max, m_dispatcher1);
    } else {
      o->setActivationState(DISABLE_SIMULATION);
    }
  }
}

// As btCollisionDispatcher::dispatchAllCollisionPairs with its default near
// callback. On this thread, in pair order: the collision filter, creating
// algorithms (and their manifolds), and colliding every pair that is not
// box-box. Then the box-box pairs, each of which writes only its own
// manifold (btBoxBoxCollisionAlgorithm owns one, made with the algorithm),
// on the pool.
void CanonicalDynamicsWorld::dispatch_pairs() {
  btOverlappingPairCache* cache = broadphase_->getOverlappingPairCache();
  const btDispatcherInfo& info = getDispatchInfo();
  SolverPool* pool = stage_pool();
  auto* dispatcher = dynamic_cast<btCollisionDispatcher*>(m_dispatcher1);
  btBroadphasePairArray& pairs = cache->getOverlappingPairArray();
  if (!pool || !dispatcher || pairs.size() < kParallelMinPairs ||
      dispatcher->getNearCallback() != &btCollisionDispatcher::defaultNearCallback ||
      info.m_dispatchFunc != btDispatcherInfo::DISPATCH_DISCRETE) {
    m_dispatcher1->dispatchAllCollisionPairs(cache, info, m_dispatcher1);
    return;
  }
  box_pairs_.clear();
  for (int i = 0; i < pairs.size(); ++i) {
    btBroadphasePair& pair = pairs[i];
    auto* obj0 = static_cast<btCollisionObject*>(pair.m_pProxy0->m_clientObject);
    auto* obj1 = static_cast<btCollisionObject*>(pair.m_pProxy1->m_clientObject);
    if (!dispatcher->needsCollision(obj0, obj1)) continue;
    if (!pair.m_algorithm) {
      btCollisionObjectWrapper w0(nullptr, obj0->getCollisionShape(), obj0, obj0->getWorldTransform(), -1, -1);
      btCollisionObjectWrapper w1(nullptr, obj1->getCollisionShape(), obj1, obj1->getWorldTransform(), -1, -1);
      pair.m_algorithm = dispatcher->findAlgorithm(&w0, &w1, nullptr, BT_CONTACT_POINT_ALGORITHMS);
      if (!pair.m_algorithm) continue;
    }
    if (is_box(obj0) && is_box(obj1)) {
      box_pairs_.push_back(i);
    } else {
      collide_pair(pair, info);
    }
  }
  note_stage_threads(run_in_chunks(pool, static_cast<int>(box_pairs_.size()), kParallelMinPairs, kPairsPerTask,
                                   [&](int begin, int end) {
                                     for (int k = begin; k < end; ++k) collide_pair(pairs[box_pairs_[k]], info);
                                   }));
}

// As btDiscreteDynamicsWorld::integrateTransforms, per body, when no body
// takes Bullet's CCD motion clamping (a sweep against the whole world) and
// speculative-contact restitution is off.
void CanonicalDynamicsWorld::integrate_bodies(btScalar time_step) {
  const int n = m_nonStaticRigidBodies.size();
  SolverPool* pool = stage_pool();
  bool per_body = pool && n >= kParallelMinBodies && !m_applySpeculativeContactRestitution;
  if (per_body && getDispatchInfo().m_useContinuous)
    for (int i = 0; i < n && per_body; ++i) per_body = m_nonStaticRigidBodies[i]->getCcdSquareMotionThreshold() == 0;
  if (!per_body) {
    btDiscreteDynamicsWorld::integrateTransforms(time_step);
    return;
  }
  btRigidBody** bodies = &m_nonStaticRigidBodies[0];
  note_stage_threads(run_in_chunks(pool, n, kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    integrateTransformsInternal(bodies + begin, end - begin, time_step);
  }));
}

}  // namespace soda
