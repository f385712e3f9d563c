// The input file format (`soda-inputs`, docs/inputs.md): a script of user
// inputs — add a body, remove one, set a body's velocity, give it an
// impulse, change the scene's gravity, a body's mass, friction, restitution
// user data or collision filter, add or remove a joint or set its motor —
// each at a scene step boundary, which `soda run --inputs FILE`
// replays through the same calls as the embedding API
// (soda::Simulation::add_body, ...), so the run ends on the same hash as the
// API and as one territory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "soda/scene/scene.h"

namespace soda {

/// One user input (runtime/user_input.h, the embedding API's Simulation).
struct UserInput {
  /// The order is the checkpoint encoding (docs/checkpoints.md): new kinds
  /// go at the end.
  enum class Kind {
    AddBody,
    RemoveBody,
    SetVelocity,
    ApplyImpulse,
    SetGravity,      // the scene's gravity, in every world (no body)
    SetMass,         // a dynamic body's mass (kg, > 0)
    SetFriction,     // a body's friction coefficient (>= 0)
    SetRestitution,  // a body's restitution coefficient (in [0, 1])
    SetUserData,     // a body's user data (Body::user_data)
    SetPose,             // a dynamic or kinematic body put at a pose (teleport): linear, orientation
    SetKinematicTarget,  // a kinematic body moved to a pose over the next step: linear, orientation
    RemoveJoint,         // a joint removed (no body): joint
    AddJoint,            // a joint added (no body): added_joint, its id in joint too
    SetJointMotor,       // a joint's motor (no body): joint, motor
    SetCollisionFilter,  // a dynamic body's collision group and mask: collision_group, collision_mask
  };
  Kind kind = Kind::SetVelocity;
  /// Applied at the boundary after scene step `step` (0: before the first
  /// step), before step + 1 begins.
  std::int64_t step = 0;
  std::uint64_t sequence = 0;  // call order; ties at one step resolve by it
  Body body;                   // AddBody: the new body (its id must be unused)
  BodyId id = 0;               // every kind but AddBody and SetGravity
  Vec3 linear = Vec3::Zero();  // SetVelocity: linear velocity; ApplyImpulse: impulse (N s) at the centre;
                               // SetGravity: the gravity (m/s^2); SetPose, SetKinematicTarget: position (m)
  Vec3 angular = Vec3::Zero(); // SetVelocity: angular velocity
  Quat orientation = Quat::Identity();  // SetPose, SetKinematicTarget: the pose's orientation (linear: its position)
  double value = 0.0;          // SetMass: mass; SetFriction: friction; SetRestitution: restitution
  std::uint64_t user_data = 0; // SetUserData
  JointId joint = 0;           // RemoveJoint, AddJoint, SetJointMotor: the joint's id (Joint::id)
  Joint added_joint;           // AddJoint: the new joint (its id must be unused)
  JointMotor motor;            // SetJointMotor: on/off, target velocity, max impulse, axis
  std::uint32_t collision_group = kDefaultCollisionGroup;  // SetCollisionFilter (Body::collision_group)
  std::uint32_t collision_mask = kAllCollisionGroups;      // SetCollisionFilter (Body::collision_mask)
};

/// True for the kinds that name a body by `id` (all but AddBody, SetGravity
/// and the joint inputs).
bool names_body(UserInput::Kind kind);

/// "add_body" | "remove_body" | "set_velocity" | "apply_impulse" |
/// "set_gravity" | "set_mass" | "set_friction" | "set_restitution" |
/// "set_user_data" | "set_pose" | "set_kinematic_target" | "remove_joint" |
/// "add_joint" | "set_joint_motor" | "set_collision_filter", the names the
/// file uses ("unknown" for a value no kind has).
const char* input_kind_name(UserInput::Kind kind);

/// Reads an input file. Returns its inputs sorted by step (stable: inputs of
/// one step keep the file's order); `sequence` is each entry's index in the
/// file.
/// Throws SceneError naming the file, the entry (index, kind and step) and
/// the field for: unreadable file, malformed JSON, wrong format or version,
/// missing, mistyped or unknown fields, a negative step, non-finite numbers,
/// an added body that is not a valid dynamic body (scene-format rules), an
/// added joint whose fields break the scene-format rules (its bodies are
/// checked by the run), a
/// value out of range (check_input_value). Ids
/// are checked against the scene by the run (Simulation's input calls).
std::vector<UserInput> load_input_file(const std::string& path);

/// The range check of a set_mass, set_friction, set_restitution,
/// set_gravity, set_pose, set_kinematic_target or set_joint_motor input's
/// value (mass > 0 and finite, friction >= 0 and finite, restitution in
/// [0, 1], gravity finite, a pose's position finite and orientation a finite
/// non-zero quaternion, a motor's velocity finite, max impulse >= 0 and
/// finite, axis -1 or 0..5):
/// empty when it holds, else the
/// reason, naming the field ("mass must be > 0 and finite, got -1"). Other
/// kinds: empty. Shared by the input file reader and the Simulation's calls.
std::string check_input_value(const UserInput& input);

/// As load_input_file, from JSON text; `source` names it in messages.
std::vector<UserInput> parse_inputs_json(const std::string& text, const std::string& source);

/// The input file text of `inputs` (numbers read back bit-identical).
std::string inputs_to_json(const std::vector<UserInput>& inputs);

}  // namespace soda
