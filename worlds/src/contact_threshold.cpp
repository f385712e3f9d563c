#include "contact_threshold.h"

#include <cmath>

namespace soda {

btScalar max_breaking_threshold() { return btScalar(std::sqrt(2.0)) * gContactBreakingThreshold; }

btScalar manifold_breaking_threshold(const btCollisionObject& a, const btCollisionObject& b) {
  const btScalar relative = btMin(a.getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold),
                                  b.getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold));
  return btMin(relative, max_breaking_threshold());
}

btPersistentManifold* CappedDispatcher::getNewManifold(const btCollisionObject* b0, const btCollisionObject* b1) {
  btPersistentManifold* m = btCollisionDispatcher::getNewManifold(b0, b1);
  m->setContactBreakingThreshold(manifold_breaking_threshold(*b0, *b1));
  return m;
}

}  // namespace soda
