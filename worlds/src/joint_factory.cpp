#include "joint_factory.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <BulletDynamics/ConstraintSolver/btGeneric6DofSpring2Constraint.h>

#include "body_factory.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {
namespace {

btTransform frame_of(const JointFrame& f) { return to_bt_transform(f.position, f.orientation); }

btScalar s(double v) { return btScalar(v); }

}  // namespace

std::unique_ptr<btTypedConstraint> make_constraint(const Joint& j, btRigidBody& a, btRigidBody& b) {
  if (id_of(&a) != j.body_a || id_of(&b) != j.body_b)
    throw std::invalid_argument("joint " + std::to_string(j.id) + ": made with bodies " +
                                std::to_string(id_of(&a)) + " and " + std::to_string(id_of(&b)) + ", not its own");
  const btTransform fa = frame_of(j.frame_a), fb = frame_of(j.frame_b);
  std::unique_ptr<btTypedConstraint> c;
  switch (j.kind) {
    case JointKind::PointToPoint:
      c = std::make_unique<btPoint2PointConstraint>(a, b, fa.getOrigin(), fb.getOrigin());
      break;
    case JointKind::Hinge: {
      auto h = std::make_unique<btHingeConstraint>(a, b, fa, fb, false);
      if (j.limited) h->setLimit(s(j.lower), s(j.upper));
      if (j.motor) h->enableAngularMotor(true, s(j.motor_velocity), s(j.motor_max_impulse));
      c = std::move(h);
      break;
    }
    case JointKind::Slider: {
      auto sl = std::make_unique<btSliderConstraint>(a, b, fa, fb, true);
      sl->setLowerLinLimit(j.limited ? s(j.lower) : btScalar(1));
      sl->setUpperLinLimit(j.limited ? s(j.upper) : btScalar(-1));
      sl->setLowerAngLimit(s(j.angular_lower));
      sl->setUpperAngLimit(s(j.angular_upper));
      if (j.motor) {
        sl->setPoweredLinMotor(true);
        sl->setTargetLinMotorVelocity(s(j.motor_velocity));
        sl->setMaxLinMotorForce(s(j.motor_max_impulse));
      }
      c = std::move(sl);
      break;
    }
    case JointKind::ConeTwist: {
      auto ct = std::make_unique<btConeTwistConstraint>(a, b, fa, fb);
      ct->setLimit(s(j.swing_span1), s(j.swing_span2), s(j.twist_span));
      c = std::move(ct);
      break;
    }
    case JointKind::Fixed: c = std::make_unique<btFixedConstraint>(a, b, fa, fb); break;
    case JointKind::Spring6Dof: {
      auto g = std::make_unique<btGeneric6DofSpring2Constraint>(a, b, fa, fb, RO_XYZ);
      g->setLinearLowerLimit(btVector3(s(j.axis_lower[0]), s(j.axis_lower[1]), s(j.axis_lower[2])));
      g->setLinearUpperLimit(btVector3(s(j.axis_upper[0]), s(j.axis_upper[1]), s(j.axis_upper[2])));
      g->setAngularLowerLimit(btVector3(s(j.axis_lower[3]), s(j.axis_lower[4]), s(j.axis_lower[5])));
      g->setAngularUpperLimit(btVector3(s(j.axis_upper[3]), s(j.axis_upper[4]), s(j.axis_upper[5])));
      for (int i = 0; i < 6; ++i) {
        const std::size_t k = static_cast<std::size_t>(i);
        if (j.stiffness[k] > 0) {
          g->enableSpring(i, true);
          g->setStiffness(i, s(j.stiffness[k]));
          g->setDamping(i, s(j.damping[k]));
          g->setEquilibriumPoint(i, btScalar(0));
        }
        if (j.motor_max_forces[k] > 0) {
          g->enableMotor(i, true);
          g->setTargetVelocity(i, s(j.motor_velocities[k]));
          g->setMaxMotorForce(i, s(j.motor_max_forces[k]));
        }
      }
      c = std::move(g);
      break;
    }
  }
  if (std::isfinite(j.breaking_impulse)) c->setBreakingImpulseThreshold(s(j.breaking_impulse));
  c->setUserConstraintId(static_cast<int>(j.id));
  return c;
}

}  // namespace soda
