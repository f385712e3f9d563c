// One manifold per compound pair (compound_contact.h).
#include "compound_contact.h"

#include <new>
#include <vector>

#include <BulletCollision/BroadphaseCollision/btBroadphaseProxy.h>
#include <BulletCollision/CollisionDispatch/btBoxBoxCollisionAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btCompoundCollisionAlgorithm.h>
#include <BulletCollision/CollisionDispatch/btActivatingCollisionAlgorithm.h>
#include <BulletCollision/CollisionShapes/btCompoundShape.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>
#include <BulletCollision/CollisionDispatch/btSphereSphereCollisionAlgorithm.h>

namespace soda {
namespace {

// A pair of bodies at least one of which is a compound: every pair of
// children (a convex body counts as its own only child) whose AABBs
// overlap is tested by the child pair's own Bullet algorithm, in child
// order, all into one manifold in the pair's body order. Bullet's compound
// algorithms always call a child's test with the compound's child first,
// which reverses the normal when the compound is the pair's body1; here a
// child test sees the bodies in the manifold's order.
class CompoundPairAlgorithm final : public btActivatingCollisionAlgorithm {
 public:
  CompoundPairAlgorithm(const btCollisionAlgorithmConstructionInfo& ci, const btCollisionObjectWrapper* w0,
                        const btCollisionObjectWrapper* w1)
      : btActivatingCollisionAlgorithm(ci, w0, w1),
        manifold_(ci.m_manifold),
        owns_(ci.m_manifold == nullptr),
        n0_(child_count(w0)),
        n1_(child_count(w1)) {
    if (owns_) manifold_ = m_dispatcher->getNewManifold(w0->getCollisionObject(), w1->getCollisionObject());
    children_.assign(static_cast<std::size_t>(n0_) * static_cast<std::size_t>(n1_), nullptr);
  }
  ~CompoundPairAlgorithm() override {
    for (btCollisionAlgorithm*& a : children_) drop(a);
    if (owns_) m_dispatcher->releaseManifold(manifold_);
  }

  void processCollision(const btCollisionObjectWrapper* w0, const btCollisionObjectWrapper* w1,
                        const btDispatcherInfo& info, btManifoldResult* result) override {
    // As Bullet's compound algorithms: refresh the points first, then the
    // children add theirs.
    result->setPersistentManifold(manifold_);
    if (manifold_->getNumContacts()) result->refreshContactPoints();
    const btCollisionObjectWrapper* wrap0 = result->getBody0Wrap();
    const btCollisionObjectWrapper* wrap1 = result->getBody1Wrap();
    for (int i = 0; i < n0_; ++i) {
      btTransform t0;
      const btCollisionShape* s0 = child(w0, i, t0);
      btCollisionObjectWrapper c0(w0, s0, w0->getCollisionObject(), t0, -1, i);
      btVector3 lo0, hi0;
      s0->getAabb(t0, lo0, hi0);
      for (int j = 0; j < n1_; ++j) {
        btCollisionAlgorithm*& algorithm = children_[static_cast<std::size_t>(i) * n1_ + j];
        btTransform t1;
        const btCollisionShape* s1 = child(w1, j, t1);
        btVector3 lo1, hi1;
        s1->getAabb(t1, lo1, hi1);
        if (!TestAabbAgainstAabb2(lo0, hi0, lo1, hi1)) {
          drop(algorithm);
          continue;
        }
        btCollisionObjectWrapper c1(w1, s1, w1->getCollisionObject(), t1, -1, j);
        if (!algorithm) algorithm = m_dispatcher->findAlgorithm(&c0, &c1, manifold_, BT_CONTACT_POINT_ALGORITHMS);
        if (!algorithm) continue;
        result->setBody0Wrap(&c0);
        result->setBody1Wrap(&c1);
        result->setShapeIdentifiersA(-1, n0_ > 1 || compound(w0) ? i : -1);
        result->setShapeIdentifiersB(-1, n1_ > 1 || compound(w1) ? j : -1);
        algorithm->processCollision(&c0, &c1, info, result);
        result->setBody0Wrap(wrap0);
        result->setBody1Wrap(wrap1);
      }
    }
    result->setPersistentManifold(manifold_);
  }

  btScalar calculateTimeOfImpact(btCollisionObject*, btCollisionObject*, const btDispatcherInfo&,
                                 btManifoldResult*) override {
    return btScalar(1);  // Bullet's CCD is off in SODA's worlds (speculative contacts instead)
  }

  void getAllContactManifolds(btManifoldArray& out) override { out.push_back(manifold_); }

 private:
  static bool compound(const btCollisionObjectWrapper* w) { return w->getCollisionShape()->isCompound(); }
  static int child_count(const btCollisionObjectWrapper* w) {
    return compound(w) ? static_cast<const btCompoundShape*>(w->getCollisionShape())->getNumChildShapes() : 1;
  }
  // Child `i` of the body (the body's own shape when it is not a compound)
  // and its world transform.
  static const btCollisionShape* child(const btCollisionObjectWrapper* w, int i, btTransform& world) {
    if (!compound(w)) {
      world = w->getWorldTransform();
      return w->getCollisionShape();
    }
    const auto* c = static_cast<const btCompoundShape*>(w->getCollisionShape());
    world = w->getWorldTransform() * c->getChildTransform(i);
    return c->getChildShape(i);
  }
  void drop(btCollisionAlgorithm*& a) {
    if (!a) return;
    a->~btCollisionAlgorithm();
    m_dispatcher->freeCollisionAlgorithm(a);
    a = nullptr;
  }

  btPersistentManifold* manifold_;
  bool owns_;
  int n0_, n1_;
  std::vector<btCollisionAlgorithm*> children_;  // per child pair (i, j): its algorithm while their AABBs overlap
};

// The configuration's algorithm pool is sized for Bullet's algorithms.
static_assert(sizeof(CompoundPairAlgorithm) <= sizeof(btCompoundCollisionAlgorithm));

struct CreateCompoundPair final : btCollisionAlgorithmCreateFunc {
  btCollisionAlgorithm* CreateCollisionAlgorithm(btCollisionAlgorithmConstructionInfo& ci,
                                                 const btCollisionObjectWrapper* w0,
                                                 const btCollisionObjectWrapper* w1) override {
    void* mem = ci.m_dispatcher1->allocateCollisionAlgorithm(sizeof(CompoundPairAlgorithm));
    return new (mem) CompoundPairAlgorithm(ci, w0, w1);
  }
};

CreateCompoundPair g_compound_pair;

// Bullet's box-box and sphere-sphere create functions drop the manifold
// they are given (they pass 0 and make their own), so a compound's box or
// sphere children would each keep a manifold. These pass it on; for a pair of
// bodies (no manifold given) they make exactly what Bullet's make.
template <class Algorithm>
struct CreateKeepingManifold final : btCollisionAlgorithmCreateFunc {
  btCollisionAlgorithm* CreateCollisionAlgorithm(btCollisionAlgorithmConstructionInfo& ci,
                                                 const btCollisionObjectWrapper* w0,
                                                 const btCollisionObjectWrapper* w1) override {
    void* mem = ci.m_dispatcher1->allocateCollisionAlgorithm(sizeof(Algorithm));
    return new (mem) Algorithm(ci.m_manifold, ci, w0, w1);
  }
};

CreateKeepingManifold<btBoxBoxCollisionAlgorithm> g_box_box;
CreateKeepingManifold<btSphereSphereCollisionAlgorithm> g_sphere_sphere;

}  // namespace

void register_compound_algorithms(btCollisionDispatcher& dispatcher) {
  for (int other = 0; other < MAX_BROADPHASE_COLLISION_TYPES; ++other) {
    if (other == COMPOUND_SHAPE_PROXYTYPE) continue;
    dispatcher.registerCollisionCreateFunc(COMPOUND_SHAPE_PROXYTYPE, other, &g_compound_pair);
    dispatcher.registerCollisionCreateFunc(other, COMPOUND_SHAPE_PROXYTYPE, &g_compound_pair);
  }
  dispatcher.registerCollisionCreateFunc(COMPOUND_SHAPE_PROXYTYPE, COMPOUND_SHAPE_PROXYTYPE, &g_compound_pair);
  dispatcher.registerCollisionCreateFunc(BOX_SHAPE_PROXYTYPE, BOX_SHAPE_PROXYTYPE, &g_box_box);
  dispatcher.registerCollisionCreateFunc(SPHERE_SHAPE_PROXYTYPE, SPHERE_SHAPE_PROXYTYPE, &g_sphere_sphere);
}

}  // namespace soda
