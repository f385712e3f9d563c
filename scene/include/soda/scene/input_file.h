// The input file format (`soda-inputs`, docs/inputs.md): a script of user
// inputs — add a body, remove one, set a body's velocity, give it an
// impulse — each at a scene step boundary, which `soda run --inputs FILE`
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
  enum class Kind { AddBody, RemoveBody, SetVelocity, ApplyImpulse };
  Kind kind = Kind::SetVelocity;
  /// Applied at the boundary after scene step `step` (0: before the first
  /// step), before step + 1 begins.
  std::int64_t step = 0;
  std::uint64_t sequence = 0;  // call order; ties at one step resolve by it
  Body body;                   // AddBody: the new body (its id must be unused)
  BodyId id = 0;               // RemoveBody, SetVelocity, ApplyImpulse
  Vec3 linear = Vec3::Zero();  // SetVelocity: linear velocity; ApplyImpulse: impulse (N s) at the centre
  Vec3 angular = Vec3::Zero(); // SetVelocity: angular velocity
};

/// "add_body" | "remove_body" | "set_velocity" | "apply_impulse", the
/// names the file uses.
const char* input_kind_name(UserInput::Kind kind);

/// Reads an input file. Returns its inputs sorted by step (stable: inputs of
/// one step keep the file's order); `sequence` is each entry's index in the
/// file.
/// Throws SceneError naming the file, the entry (index, kind and step) and
/// the field for: unreadable file, malformed JSON, wrong format or version,
/// missing, mistyped or unknown fields, a negative step, non-finite numbers,
/// an added body that is not a valid dynamic body (scene-format rules). Ids
/// are checked against the scene by the run (Simulation's input calls).
std::vector<UserInput> load_input_file(const std::string& path);

/// As load_input_file, from JSON text; `source` names it in messages.
std::vector<UserInput> parse_inputs_json(const std::string& text, const std::string& source);

/// The input file text of `inputs` (numbers read back bit-identical).
std::string inputs_to_json(const std::vector<UserInput>& inputs);

}  // namespace soda
