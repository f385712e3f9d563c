// scene/ — how a set_joint_motor input changes a joint's description
// (docs/inputs.md, "set_joint_motor"): the one rule the world holding the
// joint and the input checks follow. A hinge or slider has one motor
// (Joint::motor, motor_velocity, motor_max_impulse); a 6-DoF spring joint
// one per axis, running where its max force is > 0 (motor_velocities,
// motor_max_forces), so turning it off stores max force 0.
#pragma once

#include <string>

#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"

namespace soda {

/// "" if `motor` fits `joint`'s kind, else the reason, naming the field:
/// a point-to-point, cone-twist or fixed joint has no motor ("joint"); a
/// hinge or slider takes axis -1, a 6-DoF spring joint an axis in 0..5
/// ("axis"). The values' own range (check_input_value) is not checked here.
std::string check_joint_motor(const Joint& joint, const JointMotor& motor);

/// `joint` with `motor` set (`motor` fitting it: check_joint_motor).
Joint with_motor(const Joint& joint, const JointMotor& motor);

}  // namespace soda
