#include "soda/runtime/user_input.h"

namespace soda {

std::string describe(const UserInput& input) {
  const std::string at = " at step " + std::to_string(input.step);
  switch (input.kind) {
    case UserInput::Kind::AddBody: return "add body " + std::to_string(input.body.id) + at;
    case UserInput::Kind::RemoveBody: return "remove body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetVelocity: return "set the velocity of body " + std::to_string(input.id) + at;
    case UserInput::Kind::ApplyImpulse: return "impulse on body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetGravity: return "set the gravity" + at;
    case UserInput::Kind::SetMass: return "set the mass of body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetFriction: return "set the friction of body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetRestitution: return "set the restitution of body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetUserData: return "set the user data of body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetPose: return "set the pose of body " + std::to_string(input.id) + at;
    case UserInput::Kind::SetKinematicTarget:
      return "set the kinematic target of body " + std::to_string(input.id) + at;
    case UserInput::Kind::RemoveJoint: return "remove joint " + std::to_string(input.joint) + at;
    case UserInput::Kind::AddJoint: return "add joint " + std::to_string(input.joint) + at;
    case UserInput::Kind::SetJointMotor: return "set the motor of joint " + std::to_string(input.joint) + at;
    case UserInput::Kind::SetCollisionFilter:
      return "set the collision filter of body " + std::to_string(input.id) + at;
  }
  return "input" + at;
}

}  // namespace soda
