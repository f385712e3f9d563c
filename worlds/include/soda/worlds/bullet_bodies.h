// Conversion from the scene model to Bullet objects, shared by every kind of
// world (stock baseline, canonical world) so that they build identical bodies.
#pragma once

#include <memory>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"

namespace soda {

/// The collision shape of `shape` (Bullet's default margins): a new one,
/// but for a triangle mesh or heightfield the one shape the process shares
/// between every world and body with the same data (read-only once built;
/// built at the first call: a mesh's BVH).
std::shared_ptr<btCollisionShape> make_collision_shape(const Shape& shape);

/// Radius of a sphere about the shape's local origin that stays inside it
/// (metres): sphere and capsule: the radius; box: the smallest half extent;
/// cylinder: the smaller of radius and half height; convex hull: half the
/// smallest half extent of its local AABB (a guess that holds for hulls
/// about their centre). The sphere swept by continuous collision detection:
/// make_rigid_body stores it as a dynamic body's ccd swept sphere radius for
/// the canonical world's speculative contacts (docs/ccd.md); Bullet's own CCD
/// reads it only when a motion threshold is set (the stock world's --ccd).
double inner_radius(const Shape& shape);

/// Scene pose -> Bullet transform (rounded to btScalar).
btTransform to_bt_transform(const Vec3& position, const Quat& orientation);
btVector3 to_bt(const Vec3& v);

/// Creates a rigid body for `body` with its start transform and velocities in
/// the construction info (so its world-space inertia is right from the first
/// step), friction and restitution set; a Body::asleep one ISLAND_SLEEPING
/// with sleep timer kAsleepTimer. The body's user index is its id; a
/// dynamic body's ccd swept sphere radius is inner_radius(shape) (its CCD
/// motion threshold stays 0: Bullet's CCD off); a Body::sensor one marked
/// (mark_sensor).
/// The shape must outlive the body.
std::unique_ptr<btRigidBody> make_rigid_body(const Body& body, btCollisionShape& shape);

/// Marks a Bullet object as a Body::sensor: CF_NO_CONTACT_RESPONSE, which
/// the worlds' pair filter (collision_filter.h) and the query world read.
inline void mark_sensor(btCollisionObject& object) {
  object.setCollisionFlags(object.getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
}

/// Reads the raw state of a Bullet body (id taken from its user index).
BodyState read_body_state(const btRigidBody& body);

/// Makes a body made by make_rigid_body (or from a state) for a kinematic
/// description kinematic for Bullet: CF_KINEMATIC_OBJECT instead of
/// CF_STATIC_OBJECT, so that the solver reads its velocities.
void mark_kinematic(btRigidBody& body);

/// Writes the state of a kinematic body after `internal_steps` internal
/// steps (docs/scene-format.md, "Kinematic bodies"): transform and
/// interpolation transform at its pose then (kinematic_place: its path, then
/// its commands), linear and angular velocity of the move from the pose one
/// internal step before (as btRigidBody::saveKinematicState computes them;
/// zero at step 0 and for a teleport), and
/// activation state ACTIVE_TAG if it moved in that step, else
/// ISLAND_SLEEPING (it then acts as a static: it wakes nothing). A pure
/// function of the description, the settings and the step: every world
/// writes the same bits. Returns whether any bit of the body changed.
/// With write false, only tells whether it would change a bit.
bool write_kinematic_state(btRigidBody& body, const Body& description, const SceneSettings& settings,
                           std::int64_t internal_steps, bool write = true);

/// The state write_kinematic_state writes, as read_body_state would read
/// it back from the body: for readers that pose kinematic bodies without a
/// world (SceneReader frames, queries, sensors).
BodyState kinematic_state(const Body& description, const SceneSettings& settings, std::int64_t internal_steps);

/// Where parked islands a moving kinematic body may touch lie: its
/// broadphase AABB grown by how far any of its points moved in the step
/// (|v| h plus |w| h times the AABB's half diagonal), so that a parked body
/// it touched before the move and is leaving wakes too. Its AABB alone for a
/// body at rest.
void kinematic_touch_box(const btRigidBody& body, btScalar h, btVector3& min, btVector3& max);

/// A kinematic body that moved in the step without velocity: a teleport
/// (set_pose), from anywhere. Parking then brings back every parked island:
/// what it left may hold a contact with it.
bool kinematic_teleported(const btRigidBody& body);

/// Owns the shapes and bodies of a scene, in the scene's body order.
struct BulletBodies {
  std::vector<std::shared_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btRigidBody>> bodies;

  explicit BulletBodies(const Scene& scene);
};

}  // namespace soda
