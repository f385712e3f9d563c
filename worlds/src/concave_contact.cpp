// One manifold per convex-concave pair, in the pair's order (concave_contact.h).
#include "concave_contact.h"

#include <new>

#include <BulletCollision/BroadphaseCollision/btBroadphaseProxy.h>
#include <BulletCollision/CollisionDispatch/btActivatingCollisionAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btConvexConcaveCollisionAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>
#include <BulletCollision/CollisionShapes/btConcaveShape.h>
#include <BulletCollision/CollisionShapes/btTriangleCallback.h>
#include <BulletCollision/CollisionShapes/btTriangleShape.h>
#include <LinearMath/btAabbUtil2.h>

namespace soda {
namespace {

// Each triangle under the convex body's box, tested by its Bullet algorithm
// (as btConvexTriangleCallback::processTriangle), the bodies in the
// manifold's order: the triangle stands in for the concave body.
class TriangleTests final : public btTriangleCallback {
 public:
  TriangleTests(btDispatcher* dispatcher, btPersistentManifold* manifold, const btCollisionObjectWrapper* convex,
                const btCollisionObjectWrapper* concave, bool concave_first, const btDispatcherInfo& info,
                btManifoldResult* result, btScalar margin, const btVector3& lo, const btVector3& hi)
      : dispatcher_(dispatcher),
        manifold_(manifold),
        convex_(convex),
        concave_(concave),
        concave_first_(concave_first),
        info_(info),
        result_(result),
        margin_(margin),
        lo_(lo),
        hi_(hi) {}

  void processTriangle(btVector3* triangle, int part, int index) override {
    if (!TestTriangleAgainstAabb2(triangle, lo_, hi_)) return;
    btTriangleShape shape(triangle[0], triangle[1], triangle[2]);
    shape.setMargin(margin_);
    btCollisionObjectWrapper tri(concave_, &shape, concave_->getCollisionObject(), concave_->getWorldTransform(), part,
                                 index);
    const btCollisionObjectWrapper* a = concave_first_ ? &tri : convex_;
    const btCollisionObjectWrapper* b = concave_first_ ? convex_ : &tri;
    btCollisionAlgorithm* algorithm = dispatcher_->findAlgorithm(a, b, manifold_, BT_CONTACT_POINT_ALGORITHMS);
    if (!algorithm) return;
    const btCollisionObjectWrapper* saved = nullptr;
    if (concave_first_) {
      saved = result_->getBody0Wrap();
      result_->setBody0Wrap(&tri);
      result_->setShapeIdentifiersA(part, index);
    } else {
      saved = result_->getBody1Wrap();
      result_->setBody1Wrap(&tri);
      result_->setShapeIdentifiersB(part, index);
    }
    algorithm->processCollision(a, b, info_, result_);
    if (concave_first_) {
      result_->setBody0Wrap(saved);
    } else {
      result_->setBody1Wrap(saved);
    }
    algorithm->~btCollisionAlgorithm();
    dispatcher_->freeCollisionAlgorithm(algorithm);
  }

 private:
  btDispatcher* dispatcher_;
  btPersistentManifold* manifold_;
  const btCollisionObjectWrapper* convex_;
  const btCollisionObjectWrapper* concave_;
  bool concave_first_;
  const btDispatcherInfo& info_;
  btManifoldResult* result_;
  btScalar margin_;
  btVector3 lo_, hi_;
};

class ConcavePairAlgorithm final : public btActivatingCollisionAlgorithm {
 public:
  ConcavePairAlgorithm(const btCollisionAlgorithmConstructionInfo& ci, const btCollisionObjectWrapper* w0,
                       const btCollisionObjectWrapper* w1)
      : btActivatingCollisionAlgorithm(ci, w0, w1), manifold_(ci.m_manifold), owns_(ci.m_manifold == nullptr) {
    if (owns_) manifold_ = m_dispatcher->getNewManifold(w0->getCollisionObject(), w1->getCollisionObject());
  }
  ~ConcavePairAlgorithm() override {
    if (owns_) m_dispatcher->releaseManifold(manifold_);
  }

  void processCollision(const btCollisionObjectWrapper* w0, const btCollisionObjectWrapper* w1,
                        const btDispatcherInfo& info, btManifoldResult* result) override {
    const bool concave_first = w0->getCollisionShape()->isConcave();
    const btCollisionObjectWrapper* concave = concave_first ? w0 : w1;
    const btCollisionObjectWrapper* convex = concave_first ? w1 : w0;
    if (!concave->getCollisionShape()->isConcave() || !convex->getCollisionShape()->isConvex()) return;
    const auto* shape = static_cast<const btConcaveShape*>(concave->getCollisionShape());
    result->setPersistentManifold(manifold_);
    // As btConvexTriangleCallback::setTimeStepAndCounters: the convex
    // body's box in the concave shape's frame, grown by the triangles'
    // margin.
    const btTransform in_concave = concave->getWorldTransform().inverse() * convex->getWorldTransform();
    btVector3 lo, hi;
    convex->getCollisionShape()->getAabb(in_concave, lo, hi);
    const btScalar margin = shape->getMargin();
    const btScalar extra = margin + result->m_closestPointDistanceThreshold;
    lo -= btVector3(extra, extra, extra);
    hi += btVector3(extra, extra, extra);
    TriangleTests tests(m_dispatcher, manifold_, convex, concave, concave_first, info, result, margin, lo, hi);
    shape->processAllTriangles(&tests, lo, hi);
    if (owns_) result->refreshContactPoints();
  }

  btScalar calculateTimeOfImpact(btCollisionObject*, btCollisionObject*, const btDispatcherInfo&,
                                 btManifoldResult*) override {
    return btScalar(1);  // Bullet's CCD is off in SODA's worlds (speculative contacts instead)
  }

  void getAllContactManifolds(btManifoldArray& out) override {
    if (owns_ && manifold_) out.push_back(manifold_);
  }

 private:
  btPersistentManifold* manifold_;
  bool owns_;
};

// The configuration's algorithm pool is sized for Bullet's algorithms.
static_assert(sizeof(ConcavePairAlgorithm) <= sizeof(btConvexConcaveCollisionAlgorithm));

struct CreateConcavePair final : btCollisionAlgorithmCreateFunc {
  btCollisionAlgorithm* CreateCollisionAlgorithm(btCollisionAlgorithmConstructionInfo& ci,
                                                 const btCollisionObjectWrapper* w0,
                                                 const btCollisionObjectWrapper* w1) override {
    void* mem = ci.m_dispatcher1->allocateCollisionAlgorithm(sizeof(ConcavePairAlgorithm));
    return new (mem) ConcavePairAlgorithm(ci, w0, w1);
  }
};

CreateConcavePair g_concave_pair;

}  // namespace

void register_concave_algorithms(btCollisionDispatcher& dispatcher) {
  for (int concave : {TRIANGLE_MESH_SHAPE_PROXYTYPE, TERRAIN_SHAPE_PROXYTYPE})
    for (int convex = 0; convex < CONCAVE_SHAPES_START_HERE; ++convex) {
      dispatcher.registerCollisionCreateFunc(convex, concave, &g_concave_pair);
      dispatcher.registerCollisionCreateFunc(concave, convex, &g_concave_pair);
    }
}

}  // namespace soda
