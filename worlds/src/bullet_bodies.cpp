#include "soda/worlds/bullet_bodies.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <LinearMath/btTransformUtil.h>

#include "concave_shapes.h"
#include "same_bits.h"

namespace soda {

btVector3 to_bt(const Vec3& v) {
  return btVector3(btScalar(v.x()), btScalar(v.y()), btScalar(v.z()));
}

btTransform to_bt_transform(const Vec3& position, const Quat& orientation) {
  const Quat q = orientation.normalized();
  return btTransform(btQuaternion(btScalar(q.x()), btScalar(q.y()), btScalar(q.z()), btScalar(q.w())),
                     to_bt(position));
}

namespace {

// A btCompoundShape that owns its children (Bullet's holds pointers only).
// Its dynamic AABB tree (Bullet's default) is built from the children in
// order: the same tree, and so the same order of child tests, in every
// world that builds the shape.
class OwningCompoundShape final : public btCompoundShape {
 public:
  explicit OwningCompoundShape(int children) : btCompoundShape(true, children) {}
  void add(std::shared_ptr<btCollisionShape> child, const btTransform& pose) {
    addChildShape(pose, child.get());
    owned_.push_back(std::move(child));
  }

 private:
  std::vector<std::shared_ptr<btCollisionShape>> owned_;
};

}  // namespace

std::shared_ptr<btCollisionShape> make_collision_shape(const Shape& shape) {
  switch (shape.kind) {
    case ShapeKind::Box:
      return std::make_unique<btBoxShape>(to_bt(shape.half_extents));
    case ShapeKind::Sphere:
      return std::make_unique<btSphereShape>(btScalar(shape.radius));
    case ShapeKind::Capsule:
      return std::make_unique<btCapsuleShape>(btScalar(shape.radius), btScalar(shape.height));
    case ShapeKind::Cylinder:
      return std::make_unique<btCylinderShape>(to_bt(shape.half_extents));
    case ShapeKind::ConvexHull: {
      auto hull = std::make_unique<btConvexHullShape>();
      for (const Vec3& p : shape.points) hull->addPoint(to_bt(p), false);
      hull->recalcLocalAabb();
      return hull;
    }
    case ShapeKind::Compound: {
      auto compound = std::make_unique<OwningCompoundShape>(static_cast<int>(shape.children.size()));
      for (const CompoundChild& c : shape.children) {
        if (c.shape.kind == ShapeKind::Compound)
          throw std::invalid_argument("make_collision_shape: nested compounds are not supported");
        compound->add(make_collision_shape(c.shape), to_bt_transform(c.position, c.orientation));
      }
      return compound;
    }
    case ShapeKind::TriangleMesh:
    case ShapeKind::Heightfield:
      return shared_concave_shape(shape);
  }
  throw std::invalid_argument("make_collision_shape: unknown shape kind");
}

double inner_radius(const Shape& shape) {
  switch (shape.kind) {
    case ShapeKind::Box: return shape.half_extents.minCoeff();
    case ShapeKind::Sphere: return shape.radius;
    case ShapeKind::Capsule: return shape.radius;
    case ShapeKind::Cylinder: return std::min(shape.half_extents.x(), shape.half_extents.y());
    case ShapeKind::ConvexHull: return 0.5 * shape.local_half_extents().minCoeff();
    case ShapeKind::Compound: {
      double r = INFINITY;  // the thinnest child's
      for (const CompoundChild& c : shape.children) r = std::min(r, inner_radius(c.shape));
      return shape.children.empty() ? 0.0 : r;
    }
    case ShapeKind::TriangleMesh:
    case ShapeKind::Heightfield:
      return 0.0;  // static only: no swept sphere
  }
  return 0.0;
}

std::unique_ptr<btRigidBody> make_rigid_body(const Body& body, btCollisionShape& shape) {
  const btScalar mass = body.is_static ? btScalar(0) : btScalar(body.mass);
  btVector3 inertia(0, 0, 0);
  if (!body.is_static) shape.calculateLocalInertia(mass, inertia);
  btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, &shape, inertia);
  info.m_startWorldTransform = to_bt_transform(body.position, body.orientation);
  info.m_friction = btScalar(body.friction);
  info.m_restitution = btScalar(body.restitution);
  auto rb = std::make_unique<btRigidBody>(info);
  rb->setUserIndex(static_cast<int>(body.id));
  if (body.sensor) mark_sensor(*rb);
  if (body.kinematic) mark_kinematic(*rb);
  // Read by soda's speculative contacts only (Bullet's CCD stays off: its
  // motion threshold is 0; the stock world's --ccd sets both itself).
  if (!body.is_static) rb->setCcdSweptSphereRadius(btScalar(inner_radius(body.shape)));
  if (!body.is_static) {
    rb->setLinearVelocity(to_bt(body.linear_velocity));
    rb->setAngularVelocity(to_bt(body.angular_velocity));
    rb->setInterpolationLinearVelocity(to_bt(body.linear_velocity));
    rb->setInterpolationAngularVelocity(to_bt(body.angular_velocity));
    if (body.asleep) {
      // As a body that has just fallen asleep (scene.h, Body::asleep): it
      // stays asleep until a contact with an awake body or an input wakes it.
      rb->setActivationState(ISLAND_SLEEPING);
      rb->setDeactivationTime(btScalar(kAsleepTimer));
    }
  }
  return rb;
}

void mark_kinematic(btRigidBody& body) {
  body.setCollisionFlags((body.getCollisionFlags() & ~btCollisionObject::CF_STATIC_OBJECT) |
                         btCollisionObject::CF_KINEMATIC_OBJECT);
}

namespace {

btTransform pose_transform(const Pose& p) { return to_bt_transform(p.position, p.orientation); }

// Where a kinematic body is after `internal_steps` and how it moved into
// it: what write_kinematic_state writes and kinematic_state reads.
struct KinematicMove {
  btTransform to;
  btVector3 linear{0, 0, 0}, angular{0, 0, 0};
  bool moved = false;
};

KinematicMove kinematic_move(const Body& d, const SceneSettings& settings, std::int64_t internal_steps) {
  const KinematicPlace place = kinematic_place(d, settings, internal_steps);
  KinematicMove m{pose_transform(place.pose)};
  if (internal_steps > 0) {
    const btTransform from = pose_transform(kinematic_place(d, settings, internal_steps - 1).pose);
    m.moved = !same_bits(from, m.to);
    if (m.moved && !place.teleported) {  // a teleport moves without velocity
      const btScalar h = btScalar(settings.dt / settings.substeps);
      btTransformUtil::calculateVelocity(from, m.to, h, m.linear, m.angular);
      // +0 for -0: the solver adds +0 deltas to a kinematic body's velocity
      // and writes the sum back; the bits must not depend on which world
      // solved which island.
      m.linear += btVector3(0, 0, 0);
      m.angular += btVector3(0, 0, 0);
    }
  }
  return m;
}

}  // namespace

BodyState kinematic_state(const Body& d, const SceneSettings& settings, std::int64_t internal_steps) {
  const KinematicMove m = kinematic_move(d, settings, internal_steps);
  BodyState s;
  s.id = d.id;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s.basis[r * 3 + c] = m.to.getBasis()[r][c];
  for (int i = 0; i < 3; ++i) {
    s.origin[i] = m.to.getOrigin()[i];
    s.linear_velocity[i] = m.linear[i];
    s.angular_velocity[i] = m.angular[i];
  }
  s.activation_state = m.moved ? ACTIVE_TAG : ISLAND_SLEEPING;
  return s;
}

bool write_kinematic_state(btRigidBody& body, const Body& d, const SceneSettings& settings,
                           std::int64_t internal_steps, bool write) {
  const KinematicMove m = kinematic_move(d, settings, internal_steps);
  const btTransform& to = m.to;
  const btVector3& linear = m.linear;
  const btVector3& angular = m.angular;
  const int activation = m.moved ? ACTIVE_TAG : ISLAND_SLEEPING;
  const bool same = same_bits(body.getWorldTransform(), to) && same_bits(body.getInterpolationWorldTransform(), to) &&
                    same_bits(body.getLinearVelocity(), linear) && same_bits(body.getAngularVelocity(), angular) &&
                    same_bits(body.getInterpolationLinearVelocity(), linear) &&
                    same_bits(body.getInterpolationAngularVelocity(), angular) &&
                    body.getActivationState() == activation && body.getDeactivationTime() == btScalar(0);
  if (same || !write) return !same;
  body.setWorldTransform(to);
  body.setInterpolationWorldTransform(to);
  body.setLinearVelocity(linear);
  body.setAngularVelocity(angular);
  body.setInterpolationLinearVelocity(linear);
  body.setInterpolationAngularVelocity(angular);
  body.forceActivationState(activation);
  body.setDeactivationTime(btScalar(0));
  return true;
}

bool kinematic_teleported(const btRigidBody& body) {
  return body.isActive() && body.getLinearVelocity().isZero() && body.getAngularVelocity().isZero();
}

void kinematic_touch_box(const btRigidBody& body, btScalar h, btVector3& min, btVector3& max) {
  const btBroadphaseProxy* p = body.getBroadphaseHandle();
  min = p->m_aabbMin;
  max = p->m_aabbMax;
  const btScalar half_diagonal = (max - min).length() * btScalar(0.5);
  const btScalar grow = (body.getLinearVelocity().length() + body.getAngularVelocity().length() * half_diagonal) * h;
  const btVector3 g(grow, grow, grow);
  min -= g;
  max += g;
}

BodyState read_body_state(const btRigidBody& body) {
  BodyState s;
  s.id = static_cast<BodyId>(body.getUserIndex());
  const btTransform& t = body.getWorldTransform();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s.basis[r * 3 + c] = t.getBasis()[r][c];
  for (int i = 0; i < 3; ++i) {
    s.origin[i] = t.getOrigin()[i];
    s.linear_velocity[i] = body.getLinearVelocity()[i];
    s.angular_velocity[i] = body.getAngularVelocity()[i];
  }
  s.activation_state = body.getActivationState();
  return s;
}

BulletBodies::BulletBodies(const Scene& scene) {
  shapes.reserve(scene.bodies.size());
  bodies.reserve(scene.bodies.size());
  for (const Body& b : scene.bodies) {
    // Stock Bullet's own triangle order for a mesh (concave_shapes.h).
    shapes.push_back(b.shape.kind == ShapeKind::TriangleMesh ? stock_concave_shape(b.shape)
                                                             : make_collision_shape(b.shape));
    bodies.push_back(make_rigid_body(b, *shapes.back()));
  }
}

}  // namespace soda
