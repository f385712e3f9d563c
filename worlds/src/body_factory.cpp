// Bullet objects <-> values (see body_factory.h).
#include "body_factory.h"

#include <cstring>

#include <BulletCollision/CollisionDispatch/btCollisionWorld.h>

#include "soda/worlds/bullet_bodies.h"

namespace soda {
namespace {

void put3(btScalar* out, const btVector3& v) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}
btVector3 get3(const btScalar* in) { return btVector3(in[0], in[1], in[2]); }

void put_transform(btScalar* basis, btScalar* origin, const btTransform& t) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) basis[r * 3 + c] = t.getBasis()[r][c];
  put3(origin, t.getOrigin());
}

ContactPointState to_state(const btManifoldPoint& p) {
  ContactPointState s{};
  put3(s.local_point_a, p.m_localPointA);
  put3(s.local_point_b, p.m_localPointB);
  put3(s.position_world_on_b, p.m_positionWorldOnB);
  put3(s.position_world_on_a, p.m_positionWorldOnA);
  put3(s.normal_world_on_b, p.m_normalWorldOnB);
  s.distance = p.m_distance1;
  s.combined_friction = p.m_combinedFriction;
  s.combined_rolling_friction = p.m_combinedRollingFriction;
  s.combined_spinning_friction = p.m_combinedSpinningFriction;
  s.combined_restitution = p.m_combinedRestitution;
  s.part_id0 = p.m_partId0;
  s.part_id1 = p.m_partId1;
  s.index0 = p.m_index0;
  s.index1 = p.m_index1;
  s.contact_point_flags = p.m_contactPointFlags;
  s.applied_impulse = p.m_appliedImpulse;
  s.prev_rhs = p.m_prevRHS;
  s.applied_impulse_lateral1 = p.m_appliedImpulseLateral1;
  s.applied_impulse_lateral2 = p.m_appliedImpulseLateral2;
  s.contact_motion1 = p.m_contactMotion1;
  s.contact_motion2 = p.m_contactMotion2;
  s.contact_cfm = p.m_contactCFM;
  s.combined_contact_stiffness1 = p.m_combinedContactStiffness1;
  s.contact_erp = p.m_contactERP;
  s.combined_contact_damping1 = p.m_combinedContactDamping1;
  s.friction_cfm = p.m_frictionCFM;
  s.lifetime = p.m_lifeTime;
  put3(s.lateral_friction_dir1, p.m_lateralFrictionDir1);
  put3(s.lateral_friction_dir2, p.m_lateralFrictionDir2);
  return s;
}

void from_state(const ContactPointState& s, btManifoldPoint& p) {
  p.m_localPointA = get3(s.local_point_a);
  p.m_localPointB = get3(s.local_point_b);
  p.m_positionWorldOnB = get3(s.position_world_on_b);
  p.m_positionWorldOnA = get3(s.position_world_on_a);
  p.m_normalWorldOnB = get3(s.normal_world_on_b);
  p.m_distance1 = s.distance;
  p.m_combinedFriction = s.combined_friction;
  p.m_combinedRollingFriction = s.combined_rolling_friction;
  p.m_combinedSpinningFriction = s.combined_spinning_friction;
  p.m_combinedRestitution = s.combined_restitution;
  p.m_partId0 = s.part_id0;
  p.m_partId1 = s.part_id1;
  p.m_index0 = s.index0;
  p.m_index1 = s.index1;
  p.m_userPersistentData = nullptr;
  p.m_contactPointFlags = s.contact_point_flags;
  p.m_appliedImpulse = s.applied_impulse;
  p.m_prevRHS = s.prev_rhs;
  p.m_appliedImpulseLateral1 = s.applied_impulse_lateral1;
  p.m_appliedImpulseLateral2 = s.applied_impulse_lateral2;
  p.m_contactMotion1 = s.contact_motion1;
  p.m_contactMotion2 = s.contact_motion2;
  // Unions in Bullet: write the members that share storage in the same order
  // as they were read, the second one wins (both were read from one storage).
  p.m_contactCFM = s.contact_cfm;
  p.m_combinedContactStiffness1 = s.combined_contact_stiffness1;
  p.m_contactERP = s.contact_erp;
  p.m_combinedContactDamping1 = s.combined_contact_damping1;
  p.m_frictionCFM = s.friction_cfm;
  p.m_lifeTime = s.lifetime;
  p.m_lateralFrictionDir1 = get3(s.lateral_friction_dir1);
  p.m_lateralFrictionDir2 = get3(s.lateral_friction_dir2);
}

}  // namespace

BodyDynamicState read_dynamic_state(const btRigidBody& body) {
  BodyDynamicState s;
  put_transform(s.basis, s.origin, body.getWorldTransform());
  put_transform(s.interpolation_basis, s.interpolation_origin, body.getInterpolationWorldTransform());
  put3(s.linear_velocity, body.getLinearVelocity());
  put3(s.angular_velocity, body.getAngularVelocity());
  put3(s.interpolation_linear_velocity, body.getInterpolationLinearVelocity());
  put3(s.interpolation_angular_velocity, body.getInterpolationAngularVelocity());
  s.activation_state = body.getActivationState();
  s.deactivation_time = body.getDeactivationTime();
  s.hit_fraction = body.getHitFraction();
  return s;
}

btTransform world_transform_of(const BodyDynamicState& s) {
  btTransform t;
  t.getBasis().setValue(s.basis[0], s.basis[1], s.basis[2], s.basis[3], s.basis[4], s.basis[5], s.basis[6],
                        s.basis[7], s.basis[8]);
  t.setOrigin(get3(s.origin));
  return t;
}


btTransform interpolation_transform_of(const BodyDynamicState& s) {
  btTransform t;
  t.getBasis().setValue(s.interpolation_basis[0], s.interpolation_basis[1], s.interpolation_basis[2],
                        s.interpolation_basis[3], s.interpolation_basis[4], s.interpolation_basis[5],
                        s.interpolation_basis[6], s.interpolation_basis[7], s.interpolation_basis[8]);
  t.setOrigin(get3(s.interpolation_origin));
  return t;
}

std::unique_ptr<btRigidBody> make_body_from_state(const Body& description, btCollisionShape& shape,
                                                  const BodyDynamicState& s) {
  const btScalar mass = description.is_static ? btScalar(0) : btScalar(description.mass);
  btVector3 inertia(0, 0, 0);
  if (!description.is_static) shape.calculateLocalInertia(mass, inertia);
  btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, &shape, inertia);
  info.m_startWorldTransform = world_transform_of(s);
  info.m_friction = btScalar(description.friction);
  info.m_restitution = btScalar(description.restitution);
  auto body = std::make_unique<btRigidBody>(info);
  btRigidBody& rb = *body;
  rb.setUserIndex(static_cast<int>(description.id));
  if (description.sensor) mark_sensor(rb);
  if (description.kinematic) mark_kinematic(rb);
  if (!description.is_static) rb.setCcdSweptSphereRadius(btScalar(inner_radius(description.shape)));  // as make_rigid_body
  rb.setInterpolationWorldTransform(interpolation_transform_of(s));
  rb.setLinearVelocity(get3(s.linear_velocity));
  rb.setAngularVelocity(get3(s.angular_velocity));
  rb.setInterpolationLinearVelocity(get3(s.interpolation_linear_velocity));
  rb.setInterpolationAngularVelocity(get3(s.interpolation_angular_velocity));
  rb.setDeactivationTime(s.deactivation_time);
  rb.setHitFraction(s.hit_fraction);
  return body;
}

void apply_material(btRigidBody& rb, const Body& description, const btVector3& gravity) {
  if (!description.is_static) {
    const btScalar mass = btScalar(description.mass);
    btVector3 inertia(0, 0, 0);
    rb.getCollisionShape()->calculateLocalInertia(mass, inertia);
    rb.setMassProps(mass, inertia);
    rb.updateInertiaTensor();
    rb.setGravity(gravity);  // m_gravity = gravity * (1 / inverse mass), as addRigidBody leaves it
  }
  rb.setFriction(btScalar(description.friction));
  rb.setRestitution(btScalar(description.restitution));
}

bool same_material(const Body& a, const Body& b) {
  auto eq = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return eq(a.mass, b.mass) && eq(a.friction, b.friction) && eq(a.restitution, b.restitution) &&
         a.user_data == b.user_data;
}

void write_dynamic_state(btRigidBody& rb, const BodyDynamicState& s) {
  rb.setWorldTransform(world_transform_of(s));
  rb.updateInertiaTensor();
  rb.setInterpolationWorldTransform(interpolation_transform_of(s));
  rb.setLinearVelocity(get3(s.linear_velocity));
  rb.setAngularVelocity(get3(s.angular_velocity));
  rb.setInterpolationLinearVelocity(get3(s.interpolation_linear_velocity));
  rb.setInterpolationAngularVelocity(get3(s.interpolation_angular_velocity));
  rb.forceActivationState(s.activation_state);
  rb.setDeactivationTime(s.deactivation_time);
  rb.setHitFraction(s.hit_fraction);
}

void bullet_aabb(const btCollisionObject& object, btVector3& min, btVector3& max) {
  object.getCollisionShape()->getAabb(object.getWorldTransform(), min, max);
  const btVector3 threshold(gContactBreakingThreshold, gContactBreakingThreshold, gContactBreakingThreshold);
  min -= threshold;
  max += threshold;
  if (object.getInternalType() == btCollisionObject::CO_RIGID_BODY && !object.isStaticOrKinematicObject()) {
    btVector3 min2, max2;
    object.getCollisionShape()->getAabb(object.getInterpolationWorldTransform(), min2, max2);
    min2 -= threshold;
    max2 += threshold;
    min.setMin(min2);
    max.setMax(max2);
  }
}

static_assert(ContactPoints::kCapacity == MANIFOLD_CACHE_SIZE, "a ManifoldState holds what a btPersistentManifold can");

ManifoldState read_manifold_state(const btPersistentManifold& m) {
  ManifoldState ms;
  read_manifold_state(m, ms);
  return ms;
}

void read_manifold_state(const btPersistentManifold& m, ManifoldState& out) {
  out.id0 = static_cast<BodyId>(m.getBody0()->getUserIndex());
  out.id1 = static_cast<BodyId>(m.getBody1()->getUserIndex());
  out.points.clear();
  for (int p = 0; p < m.getNumContacts(); ++p) out.points.push_back(to_state(m.getContactPoint(p)));
}

void write_manifold_points(const ManifoldState& ms, btPersistentManifold& m) {
  m.clearManifold();
  m.setNumContacts(static_cast<int>(ms.points.size()));
  for (std::size_t i = 0; i < ms.points.size(); ++i) from_state(ms.points[i], m.getContactPoint(static_cast<int>(i)));
}

}  // namespace soda
