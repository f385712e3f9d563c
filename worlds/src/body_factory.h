// Internal: Bullet objects <-> values, shared by the canonical world (restore)
// and the territory world (ghosts, migrants, island copies). One place, so
// that every world builds a body from a state in exactly the same way.
#pragma once

#include <memory>

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/world_snapshot.h"

namespace soda {

/// Raw state of a Bullet body, bit for bit.
BodyDynamicState read_dynamic_state(const btRigidBody& body);
/// The world transform of a raw state.
btTransform world_transform_of(const BodyDynamicState& state);
/// The interpolation transform of a raw state.
btTransform interpolation_transform_of(const BodyDynamicState& state);

/// A body with its raw state: created with the state's transform in the
/// construction info (world-space inertia computed from it), then
/// interpolation transform, velocities, interpolation velocities, timer and
/// hit fraction. The activation state is left ACTIVE_TAG: callers set it once
/// the body's pairs exist (see canonical_snapshot.cpp). User index = id. The
/// shape must outlive the body.
std::unique_ptr<btRigidBody> make_body_from_state(const Body& description, btCollisionShape& shape,
                                                  const BodyDynamicState& state);

/// Gives an existing dynamic body the mass (inertia from its shape, as
/// make_body_from_state computes it), friction and restitution of
/// `description`, and re-applies `gravity` (the world's, as addRigidBody
/// sets it: its weight follows the new mass). Afterwards the body is, bit
/// for bit, what make_body_from_state(description, ...) plus addRigidBody
/// would make of its state.
void apply_material(btRigidBody& body, const Body& description, const btVector3& gravity);

/// True if a and b have the same mass, friction, restitution and user
/// data, bit for bit.
bool same_material(const Body& a, const Body& b);

/// Overwrites every field of a raw state on an existing body, activation state
/// and timer included, and recomputes its world-space inertia from the new
/// transform: afterwards the body is indistinguishable, for a step, from one
/// made by make_body_from_state (plus forceActivationState).
void write_dynamic_state(btRigidBody& body, const BodyDynamicState& state);

/// The AABB Bullet gives a body for a step, exactly as
/// btCollisionWorld::updateSingleAabb computes it (m_useContinuous on): the
/// shape's AABB at the world transform, united for dynamic bodies with the one
/// at the interpolation (predicted) transform, grown by
/// gContactBreakingThreshold. This is a body's *halo*.
void bullet_aabb(const btCollisionObject& object, btVector3& min, btVector3& max);

/// A Bullet object's body id: its user index (make_body_from_state sets it).
inline BodyId id_of(const btCollisionObject* o) { return static_cast<BodyId>(o->getUserIndex()); }

/// A Bullet vector as a value (double).
inline Vec3 to_vec3(const btVector3& v) { return Vec3(double(v.x()), double(v.y()), double(v.z())); }

/// Every field of one manifold's points, in cache order; ids from the bodies'
/// user indices.
ManifoldState read_manifold_state(const btPersistentManifold& manifold);
/// The same into `out`, reusing its points' storage.
void read_manifold_state(const btPersistentManifold& manifold, ManifoldState& out);
/// Replaces a manifold's points with the state's, in the state's order.
void write_manifold_points(const ManifoldState& state, btPersistentManifold& manifold);

}  // namespace soda
