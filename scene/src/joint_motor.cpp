#include "soda/scene/joint_motor.h"

#include <cstddef>
#include <stdexcept>

namespace soda {

std::string check_joint_motor(const Joint& joint, const JointMotor& motor) {
  switch (joint.kind) {
    case JointKind::Hinge:
    case JointKind::Slider:
      if (motor.axis != -1)
        return "axis: a " + std::string(joint_kind_name(joint.kind)) + " joint has one motor (no axis), got axis " +
               std::to_string(motor.axis);
      return {};
    case JointKind::Spring6Dof:
      if (motor.axis < 0 || motor.axis > 5)
        return "axis: a spring-6dof joint's motor needs an axis in 0..5 (x, y, z linear, then angular), got " +
               std::to_string(motor.axis);
      return {};
    default:
      return "joint: joint " + std::to_string(joint.id) + " is a " + joint_kind_name(joint.kind) +
             " joint, which has no motor (hinge, slider and spring-6dof joints have)";
  }
}

Joint with_motor(const Joint& joint, const JointMotor& motor) {
  if (const std::string why = check_joint_motor(joint, motor); !why.empty())
    throw std::invalid_argument("set the motor of joint " + std::to_string(joint.id) + ": " + why);
  Joint j = joint;
  if (j.kind == JointKind::Spring6Dof) {
    const auto axis = static_cast<std::size_t>(motor.axis);
    j.motor_velocities[axis] = motor.velocity;
    j.motor_max_forces[axis] = motor.on ? motor.max_impulse : 0.0;
  } else {
    j.motor = motor.on;
    j.motor_velocity = motor.velocity;
    j.motor_max_impulse = motor.max_impulse;
  }
  return j;
}

}  // namespace soda
