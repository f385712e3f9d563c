// Internal: a scene Joint (scene.h) as a Bullet constraint, shared by every
// world that creates joints (the canonical world, the stock world), so that
// each builds a joint in exactly the same way.
//
// A joint's step is a pure function of its island: Bullet's sequential
// impulse solver starts every joint row from zero impulse (no warm start
// across steps), so the only state a joint carries from step to step is
// whether it has broken (btTypedConstraint::isEnabled). Its applied impulse
// is written by the solve that reads it.
#pragma once

#include <memory>

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"

namespace soda {

/// The constraint of `joint` between `a` (its body_a) and `b` (its
/// body_b): Bullet's type for the kind, frames in each body's local space,
/// limits, springs, motors and breaking impulse set; user constraint id =
/// joint id. Throws std::invalid_argument for a body that is not the
/// joint's.
std::unique_ptr<btTypedConstraint> make_constraint(const Joint& joint, btRigidBody& a, btRigidBody& b);

/// The joint id of a constraint make_constraint made.
inline JointId joint_id_of(const btTypedConstraint* c) { return static_cast<JointId>(c->getUserConstraintId()); }

}  // namespace soda
