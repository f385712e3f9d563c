#include "pair_manifold.h"

#include <stdexcept>
#include <string>

#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btManifoldResult.h>

namespace soda {

btPersistentManifold& pair_manifold(btBroadphasePair& pair, btCollisionDispatcher& dispatcher,
                                    const btDispatcherInfo& info) {
  auto* obj0 = static_cast<btCollisionObject*>(pair.m_pProxy0->m_clientObject);
  auto* obj1 = static_cast<btCollisionObject*>(pair.m_pProxy1->m_clientObject);
  const std::string ids = std::to_string(obj0->getUserIndex()) + "-" + std::to_string(obj1->getUserIndex());
  btCollisionObjectWrapper w0(nullptr, obj0->getCollisionShape(), obj0, obj0->getWorldTransform(), -1, -1);
  btCollisionObjectWrapper w1(nullptr, obj1->getCollisionShape(), obj1, obj1->getWorldTransform(), -1, -1);
  btManifoldArray ms;
  if (pair.m_algorithm) pair.m_algorithm->getAllContactManifolds(ms);
  if (ms.size() == 0) {
    const int s0 = obj0->getActivationState(), s1 = obj1->getActivationState();
    if (!obj0->isStaticOrKinematicObject()) obj0->forceActivationState(ACTIVE_TAG);
    if (!obj1->isStaticOrKinematicObject()) obj1->forceActivationState(ACTIVE_TAG);
    if (!pair.m_algorithm) pair.m_algorithm = dispatcher.findAlgorithm(&w0, &w1, nullptr, BT_CONTACT_POINT_ALGORITHMS);
    if (pair.m_algorithm) {
      pair.m_algorithm->getAllContactManifolds(ms);
      if (ms.size() == 0) {
        btManifoldResult result(&w0, &w1);
        pair.m_algorithm->processCollision(&w0, &w1, info, &result);
        pair.m_algorithm->getAllContactManifolds(ms);
      }
    }
    obj0->forceActivationState(s0);
    obj1->forceActivationState(s1);
  }
  if (ms.size() != 1)
    throw std::logic_error("pair " + ids + " has " + std::to_string(ms.size()) +
                           " manifolds, expected 1 (compound shapes are not supported)");
  btPersistentManifold& m = *ms[0];
  if (m.getBody0() != obj0 || m.getBody1() != obj1)
    throw std::logic_error("pair " + ids + ": its manifold holds the bodies in the other order");
  return m;
}

}  // namespace soda
