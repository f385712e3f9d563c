#include "settled.h"

#include <cmath>
#include <cstring>

namespace soda {
namespace {

bool same_bits(const btVector3& a, const btVector3& b) {
  return std::memcmp(&a[0], &b[0], 3 * sizeof(btScalar)) == 0;
}

bool same_bits(const btTransform& a, const btTransform& b) {
  for (int r = 0; r < 3; ++r)
    if (!same_bits(a.getBasis()[r], b.getBasis()[r])) return false;
  return same_bits(a.getOrigin(), b.getOrigin());
}

}  // namespace

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
