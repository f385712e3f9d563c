#include "settled.h"

#include <cmath>

#include "same_bits.h"

namespace soda {

bool zero_bits(const btVector3& v) { return same_bits(v, btVector3(0, 0, 0)); }

bool body_settled(const btRigidBody& b, btScalar h) {
  if (b.getActivationState() != ISLAND_SLEEPING || b.getDeactivationTime() == btScalar(0)) return false;
  if (!zero_bits(b.getLinearVelocity()) || !zero_bits(b.getAngularVelocity())) return false;
  btTransform predicted;  // as btRigidBody::predictIntegratedTransform
  btTransformUtil::integrateTransform(b.getWorldTransform(), b.getLinearVelocity(), b.getAngularVelocity(), h,
                                      predicted);
  return same_bits(predicted, b.getInterpolationWorldTransform());
}

}  // namespace soda
