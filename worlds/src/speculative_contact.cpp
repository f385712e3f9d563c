// Speculative contacts for fast bodies (speculative_contact.h, docs/ccd.md).
#include "speculative_contact.h"

#include <algorithm>

namespace soda {
namespace {

btVector3 motion_of(const btCollisionObject& body) {
  if (body.isStaticOrKinematicObject()) return btVector3(0, 0, 0);
  return body.getInterpolationWorldTransform().getOrigin() - body.getWorldTransform().getOrigin();
}

}  // namespace

bool is_fast(const btCollisionObject& body) {
  if (body.isStaticOrKinematicObject()) return false;
  const btScalar r = body.getCcdSweptSphereRadius();
  return r > 0 && motion_of(body).length2() > r * r;
}

bool add_speculative_contact(btPersistentManifold& manifold) {
  if (manifold.getNumContacts() != 0) return false;
  const btCollisionObject* body0 = manifold.getBody0();
  const btCollisionObject* body1 = manifold.getBody1();
  const bool fast0 = is_fast(*body0);
  if (!fast0 && !is_fast(*body1)) return false;
  const btCollisionObject& swept = fast0 ? *body0 : *body1;
  const btCollisionObject& other = fast0 ? *body1 : *body0;
  if (!other.hasContactResponse() || !swept.hasContactResponse()) return false;

  // The swept body's inner sphere along the relative motion, against the
  // other body where it is at the step's start.
  const btScalar r = swept.getCcdSweptSphereRadius();
  const btVector3 motion = motion_of(swept) - motion_of(other);
  const btVector3 from_origin = swept.getWorldTransform().getOrigin();
  btSphereShape sphere(r);
  btTransform from, to;
  from.setIdentity();
  to.setIdentity();
  from.setOrigin(from_origin);
  to.setOrigin(from_origin + motion);
  btCollisionWorld::ClosestConvexResultCallback hit(from.getOrigin(), to.getOrigin());
  btCollisionWorld::objectQuerySingle(&sphere, from, to, const_cast<btCollisionObject*>(&other),
                                      other.getCollisionShape(), other.getWorldTransform(), hit, btScalar(0));
  if (!hit.hasHit()) return false;
  btVector3 normal = hit.m_hitNormalWorld;  // on `other`, towards the swept body
  if (!(normal.length2() > btScalar(0))) return false;
  normal.normalize();
  const btScalar approach = normal.dot(motion);
  if (!(approach < 0)) return false;  // a graze or a parting motion: nothing to stop

  // The gap along the normal, and the two points that meet: the inner
  // sphere's point facing the other body, where it is now and where it meets.
  const btScalar gap = -hit.m_closestHitFraction * approach;
  const btVector3 on_swept = from_origin - normal * r;
  const btVector3 on_other = on_swept + motion * hit.m_closestHitFraction;
  // Bullet's convention: normal on body 1 towards body 0, point on 0 = point on 1 + normal * distance.
  const bool swept_is_0 = &swept == body0;
  const btVector3 on0 = swept_is_0 ? on_swept : on_other;
  const btVector3 on1 = swept_is_0 ? on_other : on_swept;
  btManifoldPoint point(body0->getWorldTransform().invXform(on0), body1->getWorldTransform().invXform(on1),
                        swept_is_0 ? normal : -normal, gap);
  point.m_positionWorldOnA = on0;
  point.m_positionWorldOnB = on1;
  point.m_combinedFriction = 0;
  point.m_combinedRollingFriction = 0;
  point.m_combinedSpinningFriction = 0;
  point.m_combinedRestitution = 0;
  point.m_contactPointFlags = kSpeculativeContactFlag;
  manifold.addManifoldPoint(point, /*isPredictive=*/true);
  return true;
}

bool clear_speculative_contact(btPersistentManifold& manifold) {
  if (manifold.getNumContacts() == 0 || !(manifold.getContactPoint(0).m_contactPointFlags & kSpeculativeContactFlag))
    return false;
  manifold.clearManifold();
  return true;
}

bool is_speculative(const ManifoldState& manifold) {
  return std::any_of(manifold.points.begin(), manifold.points.end(), [](const ContactPointState& p) {
    return (p.contact_point_flags & kSpeculativeContactFlag) != 0;
  });
}

}  // namespace soda
